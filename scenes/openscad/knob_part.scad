// The part that stl_cutout.scad imports: a cross of two cylinders with a ball
// at the crossing, exported by OpenSCAD 2021.01 as knob_part.stl (ASCII STL).
$fn = 20;
union() {
    rotate([0, 90, 0]) cylinder(r = 3, h = 30, center = true);
    rotate([90, 0, 0]) cylinder(r = 2, h = 30, center = true);
    sphere(r = 6.5);
}
