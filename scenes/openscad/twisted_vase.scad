// A twisted, tapering extrusion of a star with a hole: linear_extrude with
// twist and scale (OpenSCAD's default slice count), then a cup cut from its top.
module star(n = 6, r1 = 10, r2 = 7) {
    polygon([for (i = [0 : 2 * n - 1])
        (i % 2 == 0 ? r1 : r2) * [cos(180 * i / n), sin(180 * i / n)]]);
}
difference() {
    linear_extrude(height = 30, twist = 90, scale = 0.7)
        difference() {
            star();
            circle(r = 3, $fn = 24);
        }
    translate([0, 0, 20]) cylinder(h = 11, r1 = 3, r2 = 6, $fn = 24);
}
