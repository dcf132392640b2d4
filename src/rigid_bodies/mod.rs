//! Rigid bodies of spring-tied constituents: the engine facility behind suspended colloids
//! (Nguyen 2021 §2.4, Eq. 2.21–2.27 and 5.2; docs/theory/colloids.md).
//!
//! A body k has a centre R, an orientation (a unit quaternion q in 3D, an angle θ in 2D), a
//! velocity V and an angular velocity ω; its reference sites sit at r̄_i = R + Q(q) b_i with the
//! body-frame offsets b_i of its shape ([`shapes`]). Each site carries a *constituent*, an
//! ordinary particle of the fluid (same mass m, same pair forces), tied to it by a linear spring:
//!
//! ```text
//! constituent:  m dv_i/dt = Σ_j F_ij + F_i,S,      F_i,S = −H (r_i − r̄_i)            (5.2)
//! body:         M dV/dt = F = Σ_{i∈k} Σ_j F_ij,   I dω/dt = T = Σ_{i∈k} (r̄_i − R) × H (r_i − r̄_i)
//!               M = n_cp m (massless sites),  I = (2/3) m Σ|b_i|² (3D),  m Σ|b_i|² (2D)
//! sites:        dr̄_i/dt = V + ω × (r̄_i − R)
//! ```
//!
//! The springs do not act on the body's translation (the thesis, L590: the body is driven by the
//! pair forces on its constituents). Its rotation follows the reaction of its ties instead — a
//! departure from the thesis, whose pair torque leaves the constituents' rotation against their
//! sites undamped and pumped, and heats the fluid (docs/theory/colloids.md "The rotational tie
//! mode"). Every shape's inertia is isotropic, so the gyroscopic term of Euler's equation
//! vanishes and ω is integrated in the space frame.
//!
//! **Time stepping** (velocity Verlet for the bodies, beside the particles' Groot–Warren step):
//! at the force evaluation of step n+1 the body moves with the force and torque of step n —
//! "the data of the previous time step" (L1366) —
//!
//! ```text
//! V ← V + ½Δt F(t)/M,   ω ← ω + ½Δt T(t)/I,   R ← R + Δt V,   q ← exp(½Δt ω) ⊗ q
//! ```
//!
//! its sites are placed, the constituents get their spring forces at the new positions, F(t+Δt)
//! and T(t+Δt) are summed from the pair forces, and V ← V + ½Δt F(t+Δt)/M, ω likewise. Because
//! the pair forces are antisymmetric, the solvent's momentum plus the bodies' Σ M V is conserved
//! exactly by this scheme (the springs exchange momentum between a body's constituents and the
//! body frame only, whose momentum is carried by V).
//!
//! **Determinism.** Every rank holds the whole body table. The force and torque on each body are
//! summed over the rank's owned constituents in fixed point ([`crate::fixed_sum`]) and reduced
//! exactly over the ranks, so every rank advances every body with the same bits, whatever the
//! decomposition or thread count; the lever arm and the spring extension use the minimum image
//! with the Lees–Edwards shift, so a body may straddle slab and periodic boundaries.
//! Constituents are the particles of global id `first_gid + k n_cp + i` (body k, site i): no
//! extra per-particle field is needed to find them. The table is checkpointed as exact words
//! ([`RigidBodies::to_json`]).

pub mod rdf;
pub mod shapes;

use crate::comm::Comm;
use crate::error::Error;
use crate::fixed_sum::FixedSum;
use crate::geometry::{Boundary, FLOW, GRADIENT, SimBox};
use crate::particles::Particles;
pub use shapes::BodyShape;

/// The state of one body. Vectors have three components in either dimension (2D: z unused;
/// the angle θ is `orientation[0]` and ω, T are along z, index 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Centre R (in the box, wrapped with the Lees–Edwards remap).
    pub centre: [f64; 3],
    /// Orientation: a unit quaternion (w, x, y, z) in 3D; (θ, 0, 0, 0) in 2D.
    pub orientation: [f64; 4],
    /// Velocity V.
    pub velocity: [f64; 3],
    /// Angular velocity ω (space frame).
    pub angular_velocity: [f64; 3],
    /// Pair force F on the constituents at the last evaluation (springs excluded).
    pub force: [f64; 3],
    /// Torque T about R at the last evaluation: the ties' reaction Σ (r̄_i − R) × H (r_i − r̄_i).
    pub torque: [f64; 3],
    /// A fixed body keeps V = 0, ω = 0 (its sites are static); its force is still summed (the
    /// drag).
    pub fixed: bool,
}

impl Body {
    /// A body at rest at `centre`, unrotated.
    pub fn at(centre: [f64; 3], fixed: bool) -> Self {
        Self {
            centre,
            orientation: [1.0, 0.0, 0.0, 0.0],
            velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
            force: [0.0; 3],
            torque: [0.0; 3],
            fixed,
        }
    }

    const WORDS: usize = 20;

    fn words(&self) -> [u64; Self::WORDS] {
        let mut w = [0u64; Self::WORDS];
        let all = self
            .centre
            .iter()
            .chain(&self.orientation)
            .chain(&self.velocity)
            .chain(&self.angular_velocity)
            .chain(&self.force)
            .chain(&self.torque);
        for (k, x) in all.enumerate() {
            w[k] = x.to_bits();
        }
        w[19] = u64::from(self.fixed);
        w
    }

    fn from_words(w: &[u64]) -> Self {
        let f = |k: usize| f64::from_bits(w[k]);
        Self {
            centre: [f(0), f(1), f(2)],
            orientation: [f(3), f(4), f(5), f(6)],
            velocity: [f(7), f(8), f(9)],
            angular_velocity: [f(10), f(11), f(12)],
            force: [f(13), f(14), f(15)],
            torque: [f(16), f(17), f(18)],
            fixed: w[19] != 0,
        }
    }
}

/// What a model asks the engine for: the bodies of a case ([`RigidBodies::new`]).
#[derive(Clone, Debug)]
pub struct RigidBodySpec {
    /// The layout of every body's sites.
    pub shape: BodyShape,
    /// Distance of the outermost site from the centre.
    pub site_radius: f64,
    /// Mass m of each constituent.
    pub constituent_mass: f64,
    /// Spring stiffness H.
    pub spring_stiffness: f64,
    /// Global id of the first constituent (the fluid's particle count).
    pub first_gid: u64,
    /// The bodies' initial centres (D components used).
    pub centres: Vec<[f64; 3]>,
    /// Whether the bodies are fixed.
    pub fixed: bool,
}

/// The table of rigid bodies, the same on every rank (module documentation).
#[derive(Clone, Debug)]
pub struct RigidBodies<const D: usize> {
    spec: RigidBodySpec,
    offsets: Vec<[f64; 3]>,
    /// The bodies.
    bodies: Vec<Body>,
    /// Step whose forces `bodies` hold.
    step: u64,
    /// Whether the forces of `step` have been summed.
    forces_known: bool,
    dt: f64,
    /// This rank's share of the constraint virial of the last evaluation (module
    /// documentation), D × D, symmetrised; scratch, rebuilt by every [`Self::couple`].
    constraint_virial: Vec<FixedSum>,
}

/// The name of the constraint virial among the parts of the `stress` observable.
pub const CONSTRAINT_STRESS_PART: &str = "constraint";

/// Minimum-image separation a − b in the box, across the Lees–Edwards plane with the offset
/// `offset` (the image of b one box up in y sits at x + s): the gradient axis first.
pub fn separation<const D: usize>(
    sim_box: &SimBox<D>,
    a: &[f64; D],
    b: &[f64; D],
    offset: f64,
) -> [f64; D] {
    let mut d: [f64; D] = std::array::from_fn(|k| a[k] - b[k]);
    for &axis in &crate::geometry::axis_order::<D>() {
        if sim_box.boundaries[axis] != Boundary::Periodic {
            continue;
        }
        let l = sim_box.lengths[axis];
        let k = (d[axis] / l).round();
        if k != 0.0 {
            d[axis] -= k * l;
            if axis == GRADIENT && sim_box.sheared() {
                d[FLOW] -= k * offset;
            }
        }
    }
    d
}

/// q ⊗ p of quaternions (w, x, y, z).
fn quaternion_product(q: &[f64; 4], p: &[f64; 4]) -> [f64; 4] {
    [
        q[0] * p[0] - q[1] * p[1] - q[2] * p[2] - q[3] * p[3],
        q[0] * p[1] + q[1] * p[0] + q[2] * p[3] - q[3] * p[2],
        q[0] * p[2] - q[1] * p[3] + q[2] * p[0] + q[3] * p[1],
        q[0] * p[3] + q[1] * p[2] - q[2] * p[1] + q[3] * p[0],
    ]
}

/// Q(q) b: the body-frame vector b rotated by the unit quaternion q.
fn rotate(q: &[f64; 4], b: &[f64; 3]) -> [f64; 3] {
    let (w, u) = (q[0], [q[1], q[2], q[3]]);
    // b + 2w (u × b) + 2 u × (u × b)
    let c = cross(&u, b);
    let cc = cross(&u, &c);
    std::array::from_fn(|k| b[k] + 2.0 * (w * c[k] + cc[k]))
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

impl<const D: usize> RigidBodies<D> {
    /// The bodies of `spec`, at rest, unrotated, with no forces yet, for time step `dt`.
    pub fn new(spec: RigidBodySpec, dt: f64) -> Self {
        let offsets = spec.shape.offsets(spec.site_radius);
        let bodies = spec
            .centres
            .iter()
            .map(|&c| Body::at(c, spec.fixed))
            .collect();
        Self {
            spec,
            offsets,
            bodies,
            step: 0,
            forces_known: false,
            dt,
            constraint_virial: vec![FixedSum::ZERO; D * D],
        }
    }

    /// The bodies.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// What they were built from.
    pub fn spec(&self) -> &RigidBodySpec {
        &self.spec
    }

    /// Sites (constituents) per body.
    pub fn sites_per_body(&self) -> usize {
        self.offsets.len()
    }

    /// Constituents of all bodies.
    pub fn constituent_count(&self) -> u64 {
        (self.bodies.len() * self.offsets.len()) as u64
    }

    /// Body mass M = n_cp m.
    pub fn body_mass(&self) -> f64 {
        self.offsets.len() as f64 * self.spec.constituent_mass
    }

    /// The (isotropic) moment of inertia of a body about its centre.
    pub fn moment_of_inertia(&self) -> f64 {
        let sum: f64 = self
            .offsets
            .iter()
            .map(|b| b[0] * b[0] + b[1] * b[1] + b[2] * b[2])
            .sum();
        let m = self.spec.constituent_mass;
        if D == 3 { 2.0 / 3.0 * m * sum } else { m * sum }
    }

    /// Body and site of the constituent with global id `gid`, if it is one.
    pub fn constituent(&self, gid: u64) -> Option<(usize, usize)> {
        let k = gid.checked_sub(self.spec.first_gid)? as usize;
        let n = self.offsets.len();
        (k < self.bodies.len() * n).then(|| (k / n, k % n))
    }

    /// The site r̄ of body `body`, site `site` (not wrapped into the box).
    pub fn site_position(&self, body: usize, site: usize) -> [f64; D] {
        let b = &self.bodies[body];
        let o = &self.offsets[site];
        let r = if D == 3 {
            rotate(&b.orientation, o)
        } else {
            let (s, c) = b.orientation[0].sin_cos();
            [c * o[0] - s * o[1], s * o[0] + c * o[1], 0.0]
        };
        std::array::from_fn(|k| b.centre[k] + r[k])
    }

    /// The constituents' global ids and initial positions (their sites), in id order.
    pub fn initial_constituents(&self) -> Vec<(u64, [f64; D])> {
        let n = self.offsets.len();
        (0..self.bodies.len())
            .flat_map(|k| (0..n).map(move |i| (k, i)))
            .map(|(k, i)| {
                (
                    self.spec.first_gid + (k * n + i) as u64,
                    self.site_position(k, i),
                )
            })
            .collect()
    }

    /// Sets each free body's velocity to the mean of its constituents' (`velocity_of(gid)`)
    /// and its angular velocity to their angular momentum about the centre over I,
    /// ω = I⁻¹ Σ_i (r̄_i − R) × m v_i (the constituents start on their sites), so the bodies
    /// start with their constituents' momentum and angular momentum. Each tie then starts
    /// relaxed in both its translational mode (M Ẍ = −n_cp H X, exact) and its rotational one
    /// (linear in the rotation between constituents and sites): a body started at rest would
    /// keep that rotational mode oscillating, undamped at linear order, on top of its thermal
    /// rotation (docs/theory/colloids.md).
    pub fn start_with_constituent_velocities(&mut self, velocity_of: impl Fn(u64) -> [f64; D]) {
        let n = self.offsets.len();
        let (m, inertia) = (self.spec.constituent_mass, self.moment_of_inertia());
        for k in 0..self.bodies.len() {
            if self.bodies[k].fixed {
                continue;
            }
            let (mut v, mut l) = ([0.0; 3], [0.0; 3]);
            for i in 0..n {
                let u = velocity_of(self.spec.first_gid + (k * n + i) as u64);
                let site = self.site_position(k, i);
                let (mut arm, mut w) = ([0.0; 3], [0.0; 3]);
                for d in 0..D {
                    v[d] += u[d];
                    arm[d] = site[d] - self.bodies[k].centre[d];
                    w[d] = u[d];
                }
                let moment = cross(&arm, &w);
                for (a, c) in l.iter_mut().zip(moment) {
                    *a += m * c;
                }
            }
            self.bodies[k].velocity = v.map(|c| c / n as f64);
            if inertia > 0.0 {
                self.bodies[k].angular_velocity = l.map(|c| c / inertia);
            }
        }
    }

    /// The coupling at the force evaluation of `step`, after every model's pair forces are in
    /// `p.force` (module documentation): on the first evaluation of a new step the bodies move
    /// with the previous step's force and torque; the constituents get their spring forces; the
    /// pair force and torque on each body are summed exactly over every rank and complete the
    /// bodies' velocities. A repeated evaluation of the same step (a virial recomputed) only
    /// adds the springs again. Collective.
    pub fn couple(
        &mut self,
        p: &mut Particles<D>,
        sim_box: &SimBox<D>,
        step: u64,
        comm: &dyn Comm,
    ) -> Result<(), Error> {
        let repeat = self.forces_known && step == self.step;
        let advance = self.forces_known && step == self.step + 1;
        let offset = sim_box.le_offset(step, self.dt);
        if advance {
            self.drift(sim_box, offset);
        }
        let (m, i) = (self.body_mass(), self.moment_of_inertia());
        let nb = self.bodies.len();
        // Per body: D force components, then the torque (3 in 3D, z in 2D).
        let width = if D == 3 { 6 } else { 3 };
        let mut sums = vec![FixedSum::ZERO; nb * width];
        let h = self.spec.spring_stiffness;
        let mut virial = vec![FixedSum::ZERO; D * D];
        for k in 0..p.n_owned {
            let Some((b, s)) = self.constituent(p.gid[k]) else {
                continue;
            };
            let site = self.site_position(b, s);
            let stretch = separation(sim_box, &p.pos[k], &site, offset);
            let f = p.force[k];
            let mut centre = [0.0; D];
            centre.copy_from_slice(&self.bodies[b].centre[..D]);
            let arm = separation(sim_box, &p.pos[k], &centre, offset);
            // The constraint virial ½[(r_i − R) ⊗ F_S + F_S ⊗ (r_i − R)], F_S = −H (r_i − r̄_i).
            for a in 0..D {
                for c in 0..D {
                    let w = -0.5 * h * (arm[a] * stretch[c] + arm[c] * stretch[a]);
                    if !FixedSum::representable(w) {
                        return Err(crate::error::Unstable::new(
                            crate::error::Quantity::PairForce,
                            Some(p.gid[k]),
                            step,
                            format!(
                                "the spring virial {w:.4e} of constituent {} of rigid body {b} \
                                 is beyond the exact sum's range at step {step}: {} (time step \
                                 too large?)",
                                p.gid[k],
                                crate::error::UNSTABLE
                            ),
                        )
                        .into());
                    }
                    virial[a * D + c].add(w);
                }
            }
            if !repeat {
                // The body turns with the reaction of its ties, T = Σ_i (r̄_i − R) × H (r_i − r̄_i),
                // not with the pair torque on its constituents (a departure from the thesis,
                // docs/theory/colloids.md "The rotational tie mode"): the tie is then an
                // action–reaction pair between the constituents and a frame of inertia I, the
                // constituents' rotation against their sites is damped by their own pair
                // friction, and nothing pumps it.
                let lever: [f64; 3] = std::array::from_fn(|d| {
                    if d < D {
                        site[d] - self.bodies[b].centre[d]
                    } else {
                        0.0
                    }
                });
                let tie: [f64; 3] =
                    std::array::from_fn(|d| if d < D { h * stretch[d] } else { 0.0 });
                let torque: [f64; 3] = if D == 3 {
                    cross(&lever, &tie)
                } else {
                    [0.0, 0.0, lever[0] * tie[1] - lever[1] * tie[0]]
                };
                let terms = f[..D]
                    .iter()
                    .chain(if D == 3 { &torque[..] } else { &torque[2..] });
                for (slot, &x) in sums[b * width..(b + 1) * width].iter_mut().zip(terms) {
                    if !FixedSum::representable(x) {
                        return Err(crate::error::Unstable::new(
                            crate::error::Quantity::PairForce,
                            Some(p.gid[k]),
                            step,
                            format!(
                                "the pair force or torque {x:.4e} on constituent {} of rigid \
                                 body {b} is beyond the exact sum's range at step {step}: {} \
                                 (time step too large?)",
                                p.gid[k],
                                crate::error::UNSTABLE
                            ),
                        )
                        .into());
                    }
                    slot.add(x);
                }
            }
            for d in 0..D {
                p.force[k][d] -= h * stretch[d];
            }
            if k % 2048 == 2047 {
                virial.iter_mut().for_each(FixedSum::normalize);
            }
        }
        virial.iter_mut().for_each(FixedSum::normalize);
        self.constraint_virial = virial;
        if repeat {
            return Ok(());
        }
        FixedSum::allreduce(comm, &mut sums);
        for (b, body) in self.bodies.iter_mut().enumerate() {
            let s = &sums[b * width..(b + 1) * width];
            let mut force = [0.0; 3];
            for d in 0..D {
                force[d] = s[d].value();
            }
            let torque = if D == 3 {
                [s[3].value(), s[4].value(), s[5].value()]
            } else {
                [0.0, 0.0, s[2].value()]
            };
            body.force = force;
            body.torque = torque;
            if advance && !body.fixed {
                let half = 0.5 * self.dt;
                for d in 0..3 {
                    body.velocity[d] += half * force[d] / m;
                    body.angular_velocity[d] += half * torque[d] / i;
                }
            }
        }
        self.step = step;
        self.forces_known = true;
        Ok(())
    }

    /// The first half kick and the drift of every free body (module documentation), then its
    /// centre wrapped into the box (across the Lees–Edwards plane V_x shifts by ∓γ̇L_y, as its
    /// constituents' velocities do).
    fn drift(&mut self, sim_box: &SimBox<D>, offset: f64) {
        let (m, i, dt) = (self.body_mass(), self.moment_of_inertia(), self.dt);
        for body in self.bodies.iter_mut().filter(|b| !b.fixed) {
            for d in 0..3 {
                body.velocity[d] += 0.5 * dt * body.force[d] / m;
                body.angular_velocity[d] += 0.5 * dt * body.torque[d] / i;
            }
            for d in 0..D {
                body.centre[d] += dt * body.velocity[d];
            }
            if D == 3 {
                let w = body.angular_velocity;
                let rate = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
                if rate > 0.0 {
                    let (s, c) = (0.5 * rate * dt).sin_cos();
                    let dq = [c, s * w[0] / rate, s * w[1] / rate, s * w[2] / rate];
                    let q = quaternion_product(&dq, &body.orientation);
                    let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
                    body.orientation = q.map(|x| x / norm);
                }
            } else {
                body.orientation[0] = (body.orientation[0] + dt * body.angular_velocity[2])
                    .rem_euclid(std::f64::consts::TAU);
            }
            let mut centre = [0.0; D];
            centre.copy_from_slice(&body.centre[..D]);
            let mut velocity = [0.0; D];
            velocity.copy_from_slice(&body.velocity[..D]);
            let mut image = [0; D];
            sim_box.wrap(&mut centre, &mut [&mut velocity], &mut image, offset, true);
            body.centre[..D].copy_from_slice(&centre);
            body.velocity[..D].copy_from_slice(&velocity);
        }
    }

    /// [⟨(V_α − U_α(Y))²⟩, ⟨(ω_α − Ω_α)²⟩] over the free bodies: the translational variance
    /// over the D components about the imposed streaming velocity U = γ̇(Y − L_y/2) x̂ at the
    /// centre, and the rotational variance over the rotational components (x, y, z in 3D; z in
    /// 2D) about the imposed flow's rotation Ω = −(γ̇/2) ẑ. Equipartition: k_BT/M and k_BT/I.
    pub fn velocity_variances(&self, sim_box: &SimBox<D>) -> [f64; 2] {
        let spin = [0.0, 0.0, -0.5 * sim_box.shear_rate];
        let rotational: &[usize] = if D == 3 { &[0, 1, 2] } else { &[2] };
        let (mut v2, mut w2, mut n) = (0.0, 0.0, 0.0);
        for b in self.bodies.iter().filter(|b| !b.fixed) {
            let mut peculiar = b.velocity;
            peculiar[FLOW] -= sim_box.streaming_velocity(b.centre[GRADIENT]);
            v2 += peculiar[..D].iter().map(|x| x * x).sum::<f64>();
            w2 += rotational
                .iter()
                .map(|&a| (b.angular_velocity[a] - spin[a]).powi(2))
                .sum::<f64>();
            n += 1.0;
        }
        if n == 0.0 {
            return [0.0; 2];
        }
        [v2 / (n * D as f64), w2 / (n * rotational.len() as f64)]
    }

    /// Each body's cloud centre, the mean position of its constituents (minimum image about
    /// the body's centre R, with the Lees–Edwards shift of `step`), from exact sums over every
    /// rank's owned constituents ([`rdf`]). Collective.
    pub fn cloud_centres(
        &self,
        p: &Particles<D>,
        sim_box: &SimBox<D>,
        step: u64,
        comm: &dyn Comm,
    ) -> Vec<[f64; D]> {
        let offset = sim_box.le_offset(step, self.dt);
        let nb = self.bodies.len();
        let mut sums = vec![FixedSum::ZERO; nb * D];
        for k in 0..p.n_owned {
            let Some((b, _)) = self.constituent(p.gid[k]) else {
                continue;
            };
            let mut centre = [0.0; D];
            centre.copy_from_slice(&self.bodies[b].centre[..D]);
            let arm = separation(sim_box, &p.pos[k], &centre, offset);
            for d in 0..D {
                sums[b * D + d].add(arm[d]);
            }
        }
        FixedSum::allreduce(comm, &mut sums);
        let n = self.offsets.len() as f64;
        (0..nb)
            .map(|b| {
                std::array::from_fn(|d| self.bodies[b].centre[d] + sums[b * D + d].value() / n)
            })
            .collect()
    }

    /// The pair counts of the colloid–solvent RDF ([`rdf`]): over the rank's owned particles
    /// that `solvent(k)` accepts and are no body's constituent, and every body, the number of
    /// minimum-image distances to the body's cloud centre in each bin [b Δr, (b + 1) Δr),
    /// b < `bins`, `(width, bins)` = (Δr, the bin count); then the number of solvent particles
    /// N_S. Exact sums reduced over the ranks. Collective.
    pub fn solvent_rdf_counts(
        &self,
        p: &Particles<D>,
        sim_box: &SimBox<D>,
        step: u64,
        (width, bins): (f64, usize),
        solvent: impl Fn(usize) -> bool,
        comm: &dyn Comm,
    ) -> (Vec<f64>, f64) {
        let centres = self.cloud_centres(p, sim_box, step, comm);
        let offset = sim_box.le_offset(step, self.dt);
        let range = bins as f64 * width;
        // The bins, then N_S.
        let mut sums = vec![FixedSum::ZERO; bins + 1];
        for k in 0..p.n_owned {
            if !solvent(k) || self.constituent(p.gid[k]).is_some() {
                continue;
            }
            sums[bins].add(1.0);
            for c in &centres {
                let d = separation(sim_box, &p.pos[k], c, offset);
                let r = d.iter().map(|x| x * x).sum::<f64>().sqrt();
                if r < range {
                    let b = ((r / width) as usize).min(bins - 1);
                    sums[b].add(1.0);
                }
            }
        }
        FixedSum::allreduce(comm, &mut sums);
        let values: Vec<f64> = sums.iter().map(FixedSum::value).collect();
        (values[..bins].to_vec(), values[bins])
    }

    /// This rank's share (its owned constituents) of the constraint virial of the last
    /// evaluation, Σ_k Σ_{i∈k} ½[(r_i − R_k) ⊗ F_i,S + F_i,S ⊗ (r_i − R_k)], flattened D × D,
    /// not yet reduced over the ranks: the suspension's part of the momentum flux besides the
    /// pair virial (module documentation; docs/theory/colloids.md).
    pub fn constraint_virial(&self) -> &[FixedSum] {
        &self.constraint_virial
    }

    /// Every word of the table (state, step, whether the forces are known), for the state
    /// digest and the checkpoint.
    pub fn words(&self) -> Vec<u64> {
        let mut w = vec![self.step, u64::from(self.forces_known)];
        for b in &self.bodies {
            w.extend(b.words());
        }
        w
    }

    /// The table as JSON of exact words (the checkpoint's `rigid_bodies` attribute).
    pub fn to_json(&self) -> String {
        serde_json::to_string(&self.words()).unwrap_or_default()
    }

    /// Restores the state written by [`Self::to_json`] into bodies built from the same case;
    /// an error names what does not match.
    pub fn restore_json(&mut self, text: &str) -> Result<(), String> {
        let w: Vec<u64> = serde_json::from_str(text)
            .map_err(|e| format!("the rigid-body table is unreadable: {e}"))?;
        let expected = 2 + self.bodies.len() * Body::WORDS;
        if w.len() != expected {
            return Err(format!(
                "the checkpoint holds {} rigid-body words, the case's {} bodies need {expected}",
                w.len(),
                self.bodies.len()
            ));
        }
        self.step = w[0];
        self.forces_known = w[1] != 0;
        for (b, chunk) in self.bodies.iter_mut().zip(w[2..].chunks_exact(Body::WORDS)) {
            *b = Body::from_words(chunk);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_by_quaternion_matches_the_axis_angle_formula() {
        // A quarter turn about z maps x to y.
        let h = std::f64::consts::FRAC_PI_4;
        let q = [h.cos(), 0.0, 0.0, h.sin()];
        let r = rotate(&q, &[1.0, 0.0, 0.0]);
        assert!((r[0]).abs() < 1e-15 && (r[1] - 1.0).abs() < 1e-15 && r[2].abs() < 1e-15);
        // Composition: two quarter turns are a half turn.
        let qq = quaternion_product(&q, &q);
        let r = rotate(&qq, &[1.0, 0.0, 0.0]);
        assert!((r[0] + 1.0).abs() < 1e-15 && r[1].abs() < 1e-15);
    }

    #[test]
    fn separation_uses_the_lees_edwards_image() {
        let sim_box = SimBox::<2> {
            lengths: [10.0, 10.0],
            boundaries: [Boundary::Periodic; 2],
            shear_rate: 0.1,
        };
        // b just above y = 0, a just below y = L_y: a's image below is at (x_a − s, y_a − L_y).
        let d = separation(&sim_box, &[5.0, 9.9], &[3.0, 0.1], 2.5);
        assert!((d[1] + 0.2).abs() < 1e-12, "{d:?}");
        assert!((d[0] - (5.0 - 2.5 - 3.0)).abs() < 1e-12, "{d:?}");
    }
}
