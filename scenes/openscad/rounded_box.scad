// A rounded box (minkowski of a box and a ball) with a slot cut by the hull of
// two cylinders, and a resized ball on top: hull, minkowski and resize.
difference() {
    minkowski() {
        cube([30, 20, 10], center = true);
        sphere(r = 3, $fn = 16);
    }
    hull() {
        translate([-8, 0, 0]) cylinder(r = 4, h = 30, center = true, $fn = 24);
        translate([8, 0, 0]) cylinder(r = 4, h = 30, center = true, $fn = 24);
    }
}
translate([0, 0, 8]) resize([16, 8, 0], auto = [false, false, true]) sphere(r = 5, $fn = 24);
