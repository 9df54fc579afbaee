//! The two readings of a union of CSG products (Kirsch, Nienhaus & Döllner §7,
//! Fig. 7): the solid as one volume (§7b, [`LayerReading::Solid`], the reference's
//! default), or each product of its sum-of-products form on its own (§7a,
//! [`LayerReading::Products`], what Kirsch's depth peeling renders): a pixel's layers
//! are then every crossing of every product's boundary, so a product inside another
//! one shows through.
//!
//! The §7a reading is the §7b one applied to a scene whose solids are the products:
//! each solid of the scene is expanded into its sum of products (with the same
//! bounding-box pruning as the GPU's, [`peeltrim::csg::products`]), and each product
//! becomes a solid of its own.
#![deny(unsafe_code)]

use peeltrim::csg::products::{sum_of_products, ProductError};
use peeltrim::csg::{Expr, Node, PositiveExpr};
use peeltrim::scene::{Scene, Solid};

/// How the layers of a union of products are counted (Kirsch, Nienhaus & Döllner §7).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LayerReading {
    /// The union as one volume: crossings of each solid's boundary (Fig. 7b).
    #[default]
    Solid,
    /// Each product on its own: crossings of each product's boundary (Fig. 7a).
    Products,
}

impl LayerReading {
    pub fn name(self) -> &'static str {
        match self {
            LayerReading::Solid => "solid",
            LayerReading::Products => "products",
        }
    }
    pub fn parse(s: &str) -> Option<Self> {
        [LayerReading::Solid, LayerReading::Products]
            .into_iter()
            .find(|r| r.name() == s)
    }
}

/// `scene` with each solid replaced by its products (products without a positive
/// literal, unbounded, are dropped like on the GPU), and for each new solid the
/// index of the solid it came from (for its opacity).
pub fn product_scene(scene: &Scene, limit: usize) -> Result<(Scene, Vec<u32>), ProductError> {
    let bounds = |prim: u32| {
        let b = peeltrim::geom::bounds(&scene.primitives[prim as usize].mesh.positions);
        (b.min.to_array(), b.max.to_array())
    };
    let mut solids = Vec::new();
    let mut origin = Vec::new();
    for (si, solid) in scene.solids.iter().enumerate() {
        let positive = PositiveExpr::from_expr(&solid.expr);
        for (pi, p) in sum_of_products(&positive, &bounds, limit)?
            .iter()
            .enumerate()
        {
            if !p.literals.iter().any(|l| !l.negated) {
                continue;
            }
            let mut nodes = Vec::new();
            let mut root = None;
            for l in &p.literals {
                nodes.push(Node::Leaf { prim: l.prim });
                if l.negated {
                    nodes.push(Node::Not(nodes.len() as u32 - 1));
                }
                let lit = nodes.len() as u32 - 1;
                root = Some(match root {
                    None => lit,
                    Some(r) => {
                        nodes.push(Node::Inter(r, lit));
                        nodes.len() as u32 - 1
                    }
                });
            }
            solids.push(Solid {
                name: format!("{}#{pi}", solid.name),
                expr: Expr {
                    nodes,
                    root: root.expect("a product with a positive literal is not empty"),
                },
            });
            origin.push(si as u32);
        }
    }
    let mut out = scene.clone();
    out.solids = solids;
    Ok((out, origin))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layers::Layers;
    use glam::DVec3;
    use peeltrim::scene::fixtures::{self, ExprBuilder};

    /// Two boxes overlapping along the view axis, as one solid `a + b`.
    fn overlapping() -> Scene {
        let prims = vec![
            fixtures::prim(
                "a",
                fixtures::box_mesh(DVec3::new(-1.0, -1.0, -1.0), DVec3::new(1.0, 1.0, 1.0)),
                [200, 0, 0],
            ),
            fixtures::prim(
                "b",
                fixtures::box_mesh(DVec3::new(-0.5, -0.5, -2.0), DVec3::new(0.5, 0.5, 0.0)),
                [0, 200, 0],
            ),
        ];
        let mut e = ExprBuilder::default();
        let (a, b) = (e.leaf(0), e.leaf(1));
        let root = e.union(a, b);
        let cam = fixtures::camera(DVec3::new(0.0, 0.0, 6.0), DVec3::ZERO, 30.0, 1.0, 20.0);
        fixtures::scene(cam, prims, e.build(root))
    }

    fn depths(scene: &Scene) -> Vec<f64> {
        centre(&Layers::new(scene))
    }

    /// The centre pixel of a 9×9 image looks straight down -z.
    fn centre(layers: &Layers<'_>) -> Vec<f64> {
        layers
            .cast_pixel(4.5, 4.5, 9, 9, None)
            .iter()
            .map(|h| h.depth)
            .collect()
    }

    #[test]
    fn products_are_counted_on_their_own() {
        let scene = overlapping();
        // One volume: enter a at z = 1, leave b at z = -2.
        let solid = depths(&scene);
        assert_eq!(solid.len(), 2, "{solid:?}");
        let (ps, origin) = product_scene(&scene, 4096).unwrap();
        assert_eq!(ps.solids.len(), 2);
        assert_eq!(origin, vec![0, 0]);
        // Each product: a's 1 and -1, b's 0 and -2 (view depths 5, 7, 6, 8).
        let prods = centre(&Layers::for_products(&ps, &scene, &origin));
        let want = [5.0, 6.0, 7.0, 8.0];
        assert_eq!(prods.len(), 4, "{prods:?}");
        for (g, w) in prods.iter().zip(want) {
            assert!((g - w).abs() < 1e-9, "{prods:?}");
        }
    }

    #[test]
    fn products_touching_at_a_face_are_one_layer_there() {
        // b moved to touch a's back face: b's front face at z = -1.
        let mut scene = overlapping();
        scene.primitives[1].mesh =
            fixtures::box_mesh(DVec3::new(-0.5, -0.5, -2.0), DVec3::new(0.5, 0.5, -1.0));
        let (ps, origin) = product_scene(&scene, 4096).unwrap();
        // Each on its own: a's two faces, b's two, the touching ones one layer.
        let got = centre(&Layers::for_products(&ps, &scene, &origin));
        let want = [5.0, 7.0, 8.0];
        assert_eq!(got.len(), 3, "{got:?}");
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-9, "{got:?}");
        }
        // The plain reading of the product scene counts both solids' crossings.
        assert_eq!(depths(&ps).len(), 4);
    }

    #[test]
    fn a_product_with_a_subtraction_keeps_its_complement() {
        // a - b as one product: the reading changes nothing.
        let mut scene = overlapping();
        let mut e = ExprBuilder::default();
        let (a, b) = (e.leaf(0), e.leaf(1));
        let root = e.diff(a, b);
        scene.solids[0].expr = e.build(root);
        let (ps, _) = product_scene(&scene, 4096).unwrap();
        assert_eq!(ps.solids.len(), 1);
        assert_eq!(depths(&ps), depths(&scene));
        assert_eq!(
            LayerReading::parse("products"),
            Some(LayerReading::Products)
        );
        assert_eq!(LayerReading::parse("volume"), None);
    }

    #[test]
    fn the_product_limit_is_an_error() {
        let scene = peeltrim::scene::fixtures::product_blowup(20);
        let err = product_scene(&scene, 4096).unwrap_err().to_string();
        assert!(err.contains("4096"), "{err}");
    }
}
