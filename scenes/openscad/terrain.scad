// A height map (terrain.dat, 16 x 12 values) as a solid, with a well bored
// through it: surface.
difference() {
    scale([2, 2, 1]) surface(file = "terrain.dat", center = true);
    translate([4, 2, 0]) cylinder(r = 3, h = 20, center = true, $fn = 24);
}
