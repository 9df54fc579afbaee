// A turned knob: a lathe profile with rotate_extrude (a full turn and a
// partial one), with a D-shaped shaft bore and grip flutes as 3D cuts.
$fn = 48;
difference() {
    rotate_extrude()
        polygon([[0, 0], [12, 0], [13, 2], [13, 8], [10, 12], [6, 14], [0, 14]]);
    // The D bore.
    translate([0, 0, -1]) linear_extrude(height = 9)
        difference() { circle(r = 3); translate([1.8, -4]) square([4, 8]); }
    // Grip flutes.
    for (a = [0 : 30 : 330]) rotate(a) translate([14.5, 0, -1]) cylinder(h = 11, r = 2.2, $fn = 16);
}
// A pointer ring around part of the skirt.
rotate_extrude(angle = 120)
    translate([13.5, 1]) square([1.5, 2]);
