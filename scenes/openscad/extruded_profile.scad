// An aluminium-style profile: a square tube with T-slots on each face and a
// bore, extruded from its 2D outline (a polygon with a hole, minus circles and
// slots), then drilled across with a 3D cylinder.
$fn = 32;
module slot() {
    translate([-1.5, 7]) square([3, 4]);
    translate([-3, 8]) square([6, 1.5]);
}
difference() {
    linear_extrude(height = 30, convexity = 4)
        difference() {
            polygon(points = [[-10, -10], [10, -10], [10, 10], [-10, 10],
                              [-6, -6], [6, -6], [6, 6], [-6, 6]],
                    paths = [[0, 1, 2, 3], [4, 5, 6, 7]]);
            for (a = [0, 90, 180, 270]) rotate(a) slot();
        }
    translate([0, 0, 15]) rotate([0, 90, 0]) cylinder(h = 30, r = 2.5, center = true);
}
// A centre bar with a bore, joined to the tube.
linear_extrude(height = 30)
    difference() {
        union() {
            square([12.5, 2], center = true);
            square([2, 12.5], center = true);
            circle(r = 3.5);
        }
        circle(r = 2);
    }
