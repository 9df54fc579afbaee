// 2D imports extruded: a flange plate from a DXF drawing (arcs, lines, bolt
// circles and a window on layer "holes") and a drop-shaped boss from an SVG
// drawing (Bézier curves, an arc, a nested hole and a stroked bar).
union() {
    difference() {
        linear_extrude(height = 4) import(file = "flange.dxf", layer = "outline");
        translate([0, 0, -1]) linear_extrude(height = 6) import(file = "flange.dxf", layer = "holes");
    }
    translate([-15, -15, 4]) linear_extrude(height = 8, scale = 0.8) import(file = "drop.svg");
}
