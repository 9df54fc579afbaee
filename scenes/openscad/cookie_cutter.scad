// A cookie cutter: a thin wall (the outline offset outwards minus the
// outline), a flange (a wider chamfered offset), and a handle rounded by a
// 2D Minkowski sum. The outline is a heart: the hull of two discs, twice.
$fn = 48;

module heart() {
    rotate(45) union() {
        hull() { square(20); translate([20, 10]) circle(r = 10); }
        hull() { square(20); translate([10, 20]) circle(r = 10); }
    }
}

union() {
    // the cutting wall, 1 thick and 15 high
    linear_extrude(height = 15) difference() {
        offset(r = 1) heart();
        heart();
    }
    // the flange, chamfered corners
    linear_extrude(height = 2) difference() {
        offset(delta = 4, chamfer = true) heart();
        offset(r = -0.5) heart();
    }
    // a handle bar across the top, its ends rounded by minkowski
    translate([0, 0, 13]) linear_extrude(height = 2)
        intersection() {
            heart();
            minkowski() {
                square([2, 34], center = true);
                circle(r = 2, $fn = 16);
            }
        }
}
