// An L-bracket with mounting holes and a fillet rib.
$fn = 32;
thick = 4;
difference() {
    union() {
        cube([40, 30, thick]);                 // base plate
        cube([thick, 30, 30]);                 // upright
        // triangular rib between plate and upright
        translate([thick, 15 - thick / 2, thick])
            rotate([90, 0, 0]) rotate([0, 0, 0])
            translate([0, 0, -thick])
            linear_rib();
    }
    // two holes through the base
    for (y = [8, 22]) translate([28, y, -1]) cylinder(r = 3, h = thick + 2);
    // one slot-ish hole through the upright
    translate([-1, 15, 20]) rotate([0, 90, 0]) cylinder(r = 4, h = thick + 2);
    // countersinks on the base holes
    for (y = [8, 22]) translate([28, y, thick - 1.5]) cylinder(r1 = 3, r2 = 5, h = 1.51);
}

// A right-angled triangular prism as a polyhedron (faces clockwise from outside).
module linear_rib() {
    polyhedron(
        points = [[0, 0, 0], [16, 0, 0], [0, 16, 0],
                  [0, 0, thick], [16, 0, thick], [0, 16, thick]],
        faces = [[0, 1, 2], [3, 5, 4], [0, 3, 4, 1], [1, 4, 5, 2], [2, 5, 3, 0]]);
}
