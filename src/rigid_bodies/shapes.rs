//! Reference-site layouts of rigid bodies: the five regular polyhedra in 3D and the
//! 19-site cylinder in 2D (Nguyen 2021 §3.2, §4.2 L873; docs/theory/colloids.md).
//!
//! Every layout is centred (Σ b_i = 0) and has an isotropic second moment
//! Σ b_i b_iᵀ = (Σ|b_i|²/D) 1 — true of the vertex set of each regular polyhedron (their
//! symmetry groups act irreducibly on R³) and of the cylinder's rings of 6 and 12 sites — so the
//! inertia tensor of equal constituent masses m is isotropic:
//!
//! ```text
//! 3D: I = Σ m (|b|² 1 − b bᵀ) = (2/3) m Σ|b_i|² 1,      2D: I_z = m Σ|b_i|²
//! ```
//!
//! and Euler's equation I dω/dt = T + (Iω) × ω reduces to I dω/dt = T (the gyroscopic term
//! vanishes). `tests` below check both properties numerically for every shape.

use serde::{Deserialize, Serialize};

/// The layout of a body's reference sites.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BodyShape {
    /// 4 sites, the vertices of a regular tetrahedron (3D).
    Tetrahedron,
    /// 6 sites, ±radius along each axis (3D).
    Octahedron,
    /// 8 sites, the vertices of a cube (3D).
    Cube,
    /// 12 sites, the vertices of a regular icosahedron (3D).
    Icosahedron,
    /// 20 sites, the vertices of a regular dodecahedron (3D).
    Dodecahedron,
    /// 19 sites in 2D: the centre, 6 at radius/2 60° apart and 12 at radius 30° apart.
    Cylinder,
}

impl BodyShape {
    /// Every shape, in the order of the case reference.
    pub const ALL: [BodyShape; 6] = [
        BodyShape::Tetrahedron,
        BodyShape::Octahedron,
        BodyShape::Cube,
        BodyShape::Icosahedron,
        BodyShape::Dodecahedron,
        BodyShape::Cylinder,
    ];

    /// The case-file name.
    pub fn name(self) -> &'static str {
        match self {
            BodyShape::Tetrahedron => "tetrahedron",
            BodyShape::Octahedron => "octahedron",
            BodyShape::Cube => "cube",
            BodyShape::Icosahedron => "icosahedron",
            BodyShape::Dodecahedron => "dodecahedron",
            BodyShape::Cylinder => "cylinder",
        }
    }

    /// The dimension the shape lives in.
    pub fn dimension(self) -> usize {
        match self {
            BodyShape::Cylinder => 2,
            _ => 3,
        }
    }

    /// Number of sites (constituents per body).
    pub fn sites(self) -> usize {
        match self {
            BodyShape::Tetrahedron => 4,
            BodyShape::Octahedron => 6,
            BodyShape::Cube => 8,
            BodyShape::Icosahedron => 12,
            BodyShape::Dodecahedron => 20,
            BodyShape::Cylinder => 19,
        }
    }

    /// The site offsets b_i in the body frame, the outermost at distance `radius` from the
    /// centre, as 3-vectors (z = 0 for the 2D cylinder).
    pub fn offsets(self, radius: f64) -> Vec<[f64; 3]> {
        let unit: Vec<[f64; 3]> = match self {
            BodyShape::Tetrahedron => vec![
                [1.0, 1.0, 1.0],
                [1.0, -1.0, -1.0],
                [-1.0, 1.0, -1.0],
                [-1.0, -1.0, 1.0],
            ],
            BodyShape::Octahedron => vec![
                [1.0, 0.0, 0.0],
                [-1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, -1.0, 0.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, -1.0],
            ],
            BodyShape::Cube => {
                let mut v = Vec::new();
                for &x in &[-1.0, 1.0] {
                    for &y in &[-1.0, 1.0] {
                        for &z in &[-1.0, 1.0] {
                            v.push([x, y, z]);
                        }
                    }
                }
                v
            }
            BodyShape::Icosahedron => {
                // (0, ±1, ±φ) and its cyclic permutations.
                let phi = 0.5 * (1.0 + 5f64.sqrt());
                let mut v = Vec::new();
                for &a in &[-1.0, 1.0] {
                    for &b in &[-phi, phi] {
                        v.push([0.0, a, b]);
                        v.push([a, b, 0.0]);
                        v.push([b, 0.0, a]);
                    }
                }
                v
            }
            BodyShape::Dodecahedron => {
                // (±1, ±1, ±1) and the cyclic permutations of (0, ±1/φ, ±φ).
                let phi = 0.5 * (1.0 + 5f64.sqrt());
                let mut v = Vec::new();
                for &x in &[-1.0, 1.0] {
                    for &y in &[-1.0, 1.0] {
                        for &z in &[-1.0, 1.0] {
                            v.push([x, y, z]);
                        }
                    }
                }
                for &a in &[-1.0 / phi, 1.0 / phi] {
                    for &b in &[-phi, phi] {
                        v.push([0.0, a, b]);
                        v.push([a, b, 0.0]);
                        v.push([b, 0.0, a]);
                    }
                }
                v
            }
            BodyShape::Cylinder => {
                let mut v = vec![[0.0, 0.0, 0.0]];
                for k in 0..6 {
                    let t = std::f64::consts::PI * k as f64 / 3.0;
                    v.push([0.5 * t.cos(), 0.5 * t.sin(), 0.0]);
                }
                for k in 0..12 {
                    let t = std::f64::consts::PI * k as f64 / 6.0;
                    v.push([t.cos(), t.sin(), 0.0]);
                }
                v
            }
        };
        let longest = unit
            .iter()
            .map(|b| (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt())
            .fold(0.0, f64::max);
        unit.iter()
            .map(|b| b.map(|c| c * radius / longest))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_are_centred_isotropic_and_of_the_given_radius() {
        for shape in BodyShape::ALL {
            let b = shape.offsets(0.3);
            assert_eq!(b.len(), shape.sites(), "{shape:?}");
            let d = shape.dimension();
            let mut centre = [0.0; 3];
            let mut second = [[0.0; 3]; 3];
            let mut longest: f64 = 0.0;
            for x in &b {
                longest = longest.max((x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt());
                for a in 0..3 {
                    centre[a] += x[a];
                    for c in 0..3 {
                        second[a][c] += x[a] * x[c];
                    }
                }
            }
            assert!((longest - 0.3).abs() < 1e-14, "{shape:?}");
            let trace: f64 = (0..d).map(|a| second[a][a]).sum();
            for a in 0..d {
                assert!(centre[a].abs() < 1e-14, "{shape:?} centre {centre:?}");
                for c in 0..d {
                    let want = if a == c { trace / d as f64 } else { 0.0 };
                    assert!(
                        (second[a][c] - want).abs() < 1e-13,
                        "{shape:?} second moment {second:?}"
                    );
                }
            }
        }
    }
}
