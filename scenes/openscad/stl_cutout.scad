// A block with an imported STL part subtracted: the part (knob_part.stl)
// leaves a ball-shaped cavity and two crossing bores.
difference() {
    cube([20, 16, 14], center = true);
    rotate([0, 0, 15]) import("knob_part.stl");
}
