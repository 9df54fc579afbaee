// An electronics enclosure: a hollow box with a grid of vent holes in the lid,
// a row of port holes on one side and screw bosses inside.
w = 60; d = 40; h = 25; wall = 2;
difference() {
    union() {
        difference() {
            cube([w, d, h]);
            translate([wall, wall, wall]) cube([w - 2 * wall, d - 2 * wall, h - wall / 2]);  // ends inside the lid: no coincident faces
        }
        for (x = [6, w - 6], y = [6, d - 6])
            translate([x, y, 0]) cylinder(r = 3, h = h - 5, $fn = 20);   // bosses
        translate([0, 0, h]) difference() {                                  // lid
            cube([w, d, wall]);
            for (x = [0 : 9], y = [0 : 5])
                translate([12 + x * 4, 10 + y * 4, -1]) cylinder(r = 1.2, h = wall + 2, $fn = 12);
        }
    }
    for (x = [6, w - 6], y = [6, d - 6])
        translate([x, y, 3]) cylinder(r = 1.4, h = h, $fn = 12);          // screw holes
    for (i = [0 : 4])
        translate([10 + i * 10, -1, 10]) rotate([-90, 0, 0]) cylinder(r = 2.5, h = wall + 2, $fn = 16); // ports
}
