// Parts whose faces coincide: OpenSCAD's preview z-fights on every one of them.
// A block with a pocket cut exactly flush with its top face, a through hole whose
// cutter ends exactly on both faces, and two blocks unioned face to face.
difference() {
    cube([20, 20, 10]);
    translate([5, 5, 5]) cube([10, 10, 5]);          // pocket: top faces coincide
    translate([10, 10, 0]) cylinder(r = 2, h = 5, $fn = 24);   // hole flush with the bottom and the pocket floor
}
translate([20, 0, 0]) cube([10, 20, 10]);             // touches the block's +x face
translate([0, 0, 10]) cube([5, 20, 3]);               // sits exactly on the top
