// The `%` background and `#` highlight modifiers, and `*` disabled.
$fn = 40;
difference() {
    sphere(r = 12);
    #cylinder(r = 4, h = 30, center = true);      // highlighted: still cut, drawn pink
    rotate([90, 0, 0]) cylinder(r = 4, h = 30, center = true);
    *cube(30, center = true);                    // disabled: ignored
}
%translate([0, 0, -16]) cube([40, 40, 2], center = true);  // background: a ghost table
color([0.2, 0.4, 0.9, 0.6]) translate([20, 0, 0]) intersection() {
    cube(14, center = true);
    sphere(r = 9);
}
