// A desk name plate: a rounded plate (offset of a square), raised and
// engraved text in Liberation Sans, and a hanging tab made with hull().
$fa = 6; $fs = 0.5;

module outline() offset(r = 3) square([74, 24], center = true);

difference() {
    union() {
        linear_extrude(height = 3) outline();
        // hanging tab: the hull of the plate's top edge and a disc
        linear_extrude(height = 3) hull() {
            translate([-10, 10]) square([20, 2]);
            translate([0, 19]) circle(r = 5);
        }
        // raised lettering
        translate([0, -2, 3]) linear_extrude(height = 1.5)
            text("peeltrim", size = 9, halign = "center", valign = "center");
    }
    // hole in the tab
    translate([0, 19, -1]) cylinder(r = 2.5, h = 5);
    // engraved line of smaller text on the underside
    translate([0, 8, -0.01]) linear_extrude(height = 1)
        mirror([1, 0, 0]) text("CSG on Vulkan", size = 3.5, halign = "center", valign = "center",
                                font = "Liberation Sans:style=Bold");
    // a chamfered groove around the lettering
    translate([0, 0, 2.2]) linear_extrude(height = 1)
        difference() {
            offset(delta = 1, chamfer = true) square([66, 17], center = true);
            square([66, 17], center = true);
        }
}
