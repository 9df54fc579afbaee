// A spur gear: a disc with trapezoid teeth, a bore, a keyway and lightening holes.
teeth = 18;
r_root = 20;
tooth_h = 4;
width = 6;
difference() {
    union() {
        cylinder(r = r_root, h = width, $fn = 72);
        for (i = [0 : teeth - 1])
            rotate([0, 0, i * 360 / teeth])
                translate([r_root - 0.5, 0, 0])
                    tooth();
        cylinder(r = 8, h = width + 4, $fn = 48);          // hub
    }
    translate([0, 0, -1]) cylinder(r = 4, h = width + 6, $fn = 32);   // bore
    translate([3, -1, -1]) cube([2.5, 2, width + 6]);                  // keyway
    for (i = [0 : 5])
        rotate([0, 0, i * 60 + 30]) translate([14, 0, -1])
            cylinder(r = 3, h = width + 2, $fn = 24);                  // lightening holes
}

module tooth() {
    // trapezoid prism, clockwise faces seen from outside
    polyhedron(
        points = [[0, -2.2, 0], [tooth_h + 0.5, -1.0, 0], [tooth_h + 0.5, 1.0, 0], [0, 2.2, 0],
                  [0, -2.2, width], [tooth_h + 0.5, -1.0, width], [tooth_h + 0.5, 1.0, width], [0, 2.2, width]],
        faces = [[0, 1, 2, 3], [4, 7, 6, 5], [0, 4, 5, 1], [1, 5, 6, 2], [2, 6, 7, 3], [3, 7, 4, 0]]);
}
