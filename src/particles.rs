//! Particle storage: owned particles first (`0..n_owned`), then ghosts (`n_owned..len`).
//!
//! Core fields are stored as arrays of `[f64; D]`. Models register extra per-particle fields:
//! fixed-width ones ([`ExtraField`], e.g. a stress tensor, D² numbers) and variable-length ones
//! ([`VarField`], e.g. an ensemble of N_d connector vectors). Both migrate with their particle
//! and enter the state digest unless their [`FieldFlags`] say otherwise (a field derived anew
//! every step, such as an SPH density, does neither); fixed-width fields are sent to ghosts
//! when a model's pass asks for them ([`crate::domain::HaloPlan::refresh_fields`]).

use rayon::prelude::*;

/// A D × D tensor (a velocity gradient κ_αβ = ∂v_α/∂x_β, a stress, a conformation tensor).
/// Fields store it row-major in D² plain numbers (so it migrates, checkpoints and travels to
/// ghosts like any field); kernels read and write it as this type through
/// [`Particles::tensor`] and [`Particles::set_tensor`] (the same bytes, no cost in release
/// builds; docs/architecture.md, "Output, checkpoints, runs").
pub type Tensor<const D: usize> = nalgebra::SMatrix<f64, D, D>;

/// The rows of a [`Tensor`], κ[α][β] = κ_αβ: the form of the hot loops that index components
/// directly (the dumbbell drift, benchmarked as such in `benches/dumbbells.rs`).
pub fn tensor_rows<const D: usize>(t: &Tensor<D>) -> [[f64; D]; D] {
    std::array::from_fn(|a| std::array::from_fn(|b| t[(a, b)]))
}

/// How the engine treats a registered fixed-width field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FieldFlags {
    /// Travels with its particle when the particle changes rank.
    pub migrates: bool,
    /// Written to checkpoints (and expected back from them).
    pub checkpointed: bool,
    /// Enters the state digest.
    pub digested: bool,
    /// Transforms like a velocity (width D): its ghost copies get the Lees–Edwards velocity
    /// shift ±γ̇L_y, like the ghosts' velocities. Nothing else does.
    pub velocity_like: bool,
}

impl FieldFlags {
    /// Per-particle state (a stress tensor, a conformation vector): migrates, is checkpointed
    /// and enters the digest.
    pub const STATE: Self = Self {
        migrates: true,
        checkpointed: true,
        digested: true,
        velocity_like: false,
    };
    /// Derived anew from the positions and velocities every step (a summation density, a
    /// velocity gradient): none of that.
    pub const DERIVED: Self = Self {
        migrates: false,
        checkpointed: false,
        digested: false,
        velocity_like: false,
    };
}

/// A fixed-width per-particle field, `width` numbers per particle (owned and ghosts).
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraField {
    /// Name (appears in outputs).
    pub name: String,
    /// Numbers per particle.
    pub width: usize,
    /// How the engine treats it.
    pub flags: FieldFlags,
    /// `width × len` numbers.
    pub data: Vec<f64>,
}

/// Storage precision of a variable-length field (and the case key that chooses it for the
/// dumbbells' connectors, `polymer.precision = "double" | "single"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    /// f64 (8 bytes per number).
    #[default]
    Double,
    /// f32: half the memory of the largest state (dumbbell ensembles); a kernel widens a row to
    /// f64, works in f64 and rounds back, so the storage adds a relative error of 2⁻²⁴ per step.
    Single,
}

/// How a variable-length field stores its rows: numbers in a [`Precision`], or 64-bit words
/// that are no numbers (a BDDFS histogram's packed (cell, count) entries).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarStorage {
    /// f64 numbers.
    Double,
    /// f32 numbers.
    Single,
    /// u64 words (copied, migrated, checkpointed and digested bit for bit).
    Words,
}

impl From<Precision> for VarStorage {
    fn from(p: Precision) -> Self {
        match p {
            Precision::Double => VarStorage::Double,
            Precision::Single => VarStorage::Single,
        }
    }
}

/// The rows of a variable-length field, one per owned particle, in its storage.
#[derive(Clone, Debug, PartialEq)]
pub enum VarData {
    /// f64 rows.
    Double(Vec<Vec<f64>>),
    /// f32 rows.
    Single(Vec<Vec<f32>>),
    /// u64 rows (words, not numbers).
    Words(Vec<Vec<u64>>),
}

impl Default for VarData {
    fn default() -> Self {
        VarData::Double(Vec::new())
    }
}

impl VarData {
    /// No rows, in `storage`.
    pub fn empty(storage: VarStorage) -> Self {
        match storage {
            VarStorage::Double => VarData::Double(Vec::new()),
            VarStorage::Single => VarData::Single(Vec::new()),
            VarStorage::Words => VarData::Words(Vec::new()),
        }
    }

    /// The storage.
    pub fn storage(&self) -> VarStorage {
        match self {
            VarData::Double(_) => VarStorage::Double,
            VarData::Single(_) => VarStorage::Single,
            VarData::Words(_) => VarStorage::Words,
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        match self {
            VarData::Double(r) => r.len(),
            VarData::Single(r) => r.len(),
            VarData::Words(r) => r.len(),
        }
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Length of row `i`.
    pub fn row_len(&self, i: usize) -> usize {
        match self {
            VarData::Double(r) => r[i].len(),
            VarData::Single(r) => r[i].len(),
            VarData::Words(r) => r[i].len(),
        }
    }

    /// Row `i` widened to f64 (exact), appended to `out`; words travel as their bit patterns
    /// (`f64::from_bits`, the migration buffer's form of a particle id too).
    pub fn extend_f64(&self, i: usize, out: &mut Vec<f64>) {
        match self {
            VarData::Double(r) => out.extend_from_slice(&r[i]),
            VarData::Single(r) => out.extend(r[i].iter().map(|&x| f64::from(x))),
            VarData::Words(r) => out.extend(r[i].iter().map(|&w| f64::from_bits(w))),
        }
    }

    /// Appends a row given in f64 (narrowed for single storage: exact for values that came
    /// from f32 storage, as migrated rows do; words: the bit patterns of [`Self::extend_f64`]).
    pub fn push_f64(&mut self, row: &[f64]) {
        match self {
            VarData::Double(r) => r.push(row.to_vec()),
            VarData::Single(r) => r.push(row.iter().map(|&x| x as f32).collect()),
            VarData::Words(r) => r.push(row.iter().map(|x| x.to_bits()).collect()),
        }
    }

    /// Appends an empty row.
    pub fn push_empty(&mut self) {
        match self {
            VarData::Double(r) => r.push(Vec::new()),
            VarData::Single(r) => r.push(Vec::new()),
            VarData::Words(r) => r.push(Vec::new()),
        }
    }

    /// The bit patterns of row `i` (digests and checksums).
    pub fn extend_bits(&self, i: usize, out: &mut Vec<u64>) {
        match self {
            VarData::Double(r) => out.extend(r[i].iter().map(|x| x.to_bits())),
            VarData::Single(r) => out.extend(r[i].iter().map(|x| u64::from(x.to_bits()))),
            VarData::Words(r) => out.extend_from_slice(&r[i]),
        }
    }

    /// The f64 rows, if stored in double precision.
    pub fn double(&self) -> Option<&Vec<Vec<f64>>> {
        match self {
            VarData::Double(r) => Some(r),
            _ => None,
        }
    }

    /// The f64 rows, mutably, if stored in double precision.
    pub fn double_mut(&mut self) -> Option<&mut Vec<Vec<f64>>> {
        match self {
            VarData::Double(r) => Some(r),
            _ => None,
        }
    }

    /// The f32 rows, mutably, if stored in single precision.
    pub fn single_mut(&mut self) -> Option<&mut Vec<Vec<f32>>> {
        match self {
            VarData::Single(r) => Some(r),
            _ => None,
        }
    }

    /// The word rows, if stored as words.
    pub fn words(&self) -> Option<&Vec<Vec<u64>>> {
        match self {
            VarData::Words(r) => Some(r),
            _ => None,
        }
    }

    /// The word rows, mutably, if stored as words.
    pub fn words_mut(&mut self) -> Option<&mut Vec<Vec<u64>>> {
        match self {
            VarData::Words(r) => Some(r),
            _ => None,
        }
    }

    /// Reorders the rows: new row k is old row `order[k]` (moved, not cloned).
    fn permute(&mut self, order: &[u32]) {
        fn moved<T: Default>(rows: &mut Vec<T>, order: &[u32]) {
            let mut old = std::mem::take(rows);
            *rows = order
                .iter()
                .map(|&o| std::mem::take(&mut old[o as usize]))
                .collect();
        }
        match self {
            VarData::Double(r) => moved(r, order),
            VarData::Single(r) => moved(r, order),
            VarData::Words(r) => moved(r, order),
        }
    }

    /// Keeps the rows for which `keep` is true.
    fn retain(&mut self, keep: &[bool]) {
        fn kept<T>(rows: &mut Vec<T>, keep: &[bool]) {
            let mut k = keep.iter();
            rows.retain(|_| *k.next().expect("one flag per row"));
        }
        match self {
            VarData::Double(r) => kept(r, keep),
            VarData::Single(r) => kept(r, keep),
            VarData::Words(r) => kept(r, keep),
        }
    }
}

/// A variable-length per-particle field, owned particles only.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct VarField {
    /// Name (appears in outputs).
    pub name: String,
    /// One row per owned particle.
    pub data: VarData,
}

/// One ghost as the halo makes it: identity, position and velocity of its image, species.
#[derive(Clone, Copy, Debug)]
pub struct Ghost<const D: usize> {
    pub gid: u64,
    pub pos: [f64; D],
    pub vel: [f64; D],
    pub species: u8,
}

/// All particles a rank holds.
#[derive(Clone, Debug, Default)]
pub struct Particles<const D: usize> {
    /// Number of owned particles; the rest are ghosts.
    pub n_owned: usize,
    /// Global ids (owned and ghosts; a ghost carries its original's id).
    pub gid: Vec<u64>,
    /// Positions (owned and ghosts).
    pub pos: Vec<[f64; D]>,
    /// Velocities as seen by the forces (owned and ghosts).
    pub vel: Vec<[f64; D]>,
    /// Forces on owned particles.
    pub force: Vec<[f64; D]>,
    /// Half-step velocity v + ½Δt f/m of owned particles (integrator scratch that must migrate).
    pub vel_half: Vec<[f64; D]>,
    /// Periodic crossings of owned particles.
    pub image: Vec<[i32; D]>,
    /// Species of owned particles and ghosts (an index into the scene's species table), or
    /// `None` when the scene has one species, which then costs nothing: no storage, no word in
    /// migration or halo messages, nothing in the digest.
    pub species: Option<Vec<u8>>,
    /// Registered fixed-width fields.
    pub extra: Vec<ExtraField>,
    /// Registered variable-length fields.
    pub var: Vec<VarField>,
}

impl<const D: usize> Particles<D> {
    /// Total held (owned + ghosts).
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// Whether the rank holds nothing.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// The same registered fields, no particles.
    pub fn empty_like(&self) -> Self {
        Self {
            extra: self
                .extra
                .iter()
                .map(|f| ExtraField {
                    name: f.name.clone(),
                    width: f.width,
                    flags: f.flags,
                    data: Vec::new(),
                })
                .collect(),
            var: self
                .var
                .iter()
                .map(|f| VarField {
                    name: f.name.clone(),
                    data: VarData::empty(f.data.storage()),
                })
                .collect(),
            species: self.species.as_ref().map(|_| Vec::new()),
            ..Self::default()
        }
    }

    /// The owned particles' core fields (id, position, velocity, force, v_half, image), without
    /// ghosts or registered fields.
    pub fn owned_core(&self) -> Self {
        let n = self.n_owned;
        Self {
            n_owned: n,
            gid: self.gid[..n].to_vec(),
            pos: self.pos[..n].to_vec(),
            vel: self.vel[..n].to_vec(),
            force: self.force[..n].to_vec(),
            vel_half: self.vel_half[..n].to_vec(),
            image: self.image[..n].to_vec(),
            species: self.species.as_ref().map(|s| s[..n].to_vec()),
            extra: Vec::new(),
            var: Vec::new(),
        }
    }

    /// Species of particle `i` (owned or ghost): 0 in a one-species scene.
    #[inline]
    pub fn species_of(&self, i: usize) -> u8 {
        self.species.as_ref().map_or(0, |s| s[i])
    }

    /// Gives the owned particles species (no ghosts may exist: the next halo build sends them
    /// to the ghosts).
    pub fn assign_species(&mut self, species_of: impl Fn(usize) -> u8) {
        assert_eq!(self.n_owned, self.len(), "ghosts must be dropped first");
        self.species = Some((0..self.n_owned).map(species_of).collect());
    }

    /// Particle `i`'s value of the tensor field `field` (D² numbers, row-major).
    #[inline]
    pub fn tensor(&self, field: usize, i: usize) -> Tensor<D> {
        let f = &self.extra[field];
        debug_assert_eq!(f.width, D * D);
        Tensor::<D>::from_row_slice(&f.data[i * D * D..(i + 1) * D * D])
    }

    /// Sets particle `i`'s value of the tensor field `field` (stored row-major).
    #[inline]
    pub fn set_tensor(&mut self, field: usize, i: usize, t: &Tensor<D>) {
        let f = &mut self.extra[field];
        debug_assert_eq!(f.width, D * D);
        for a in 0..D {
            for b in 0..D {
                f.data[i * D * D + a * D + b] = t[(a, b)];
            }
        }
    }

    /// Index of the fixed-width field called `name`.
    pub fn extra_index(&self, name: &str) -> Option<usize> {
        self.extra.iter().position(|f| f.name == name)
    }

    /// Registers a fixed-width state field ([`FieldFlags::STATE`]) initialised to zero;
    /// returns its index.
    pub fn register_extra(&mut self, name: &str, width: usize) -> usize {
        self.register_field(name, width, FieldFlags::STATE)
            .expect("a new field")
    }

    /// Registers a fixed-width field initialised to zero, or, if a field of that name exists
    /// already (brought by a checkpoint), gives it `flags`; returns its index. An existing
    /// field of another width is an error.
    pub fn register_field(
        &mut self,
        name: &str,
        width: usize,
        flags: FieldFlags,
    ) -> Result<usize, String> {
        if let Some(k) = self.extra_index(name) {
            let f = &mut self.extra[k];
            if f.width != width {
                return Err(format!(
                    "the field {name} has {} numbers per particle, {width} expected",
                    f.width
                ));
            }
            f.flags = flags;
            return Ok(k);
        }
        self.extra.push(ExtraField {
            name: name.to_owned(),
            width,
            flags,
            data: vec![0.0; width * self.len()],
        });
        Ok(self.extra.len() - 1)
    }

    /// Registers a variable-length f64 field (empty rows); returns its index.
    pub fn register_var(&mut self, name: &str) -> usize {
        self.register_var_in(name, VarStorage::Double)
    }

    /// Registers a variable-length field stored in `storage` (empty rows); returns its index.
    pub fn register_var_in(&mut self, name: &str, storage: VarStorage) -> usize {
        let mut data = VarData::empty(storage);
        for _ in 0..self.n_owned {
            data.push_empty();
        }
        self.var.push(VarField {
            name: name.to_owned(),
            data,
        });
        self.var.len() - 1
    }

    /// Appends an owned particle (before any ghost exists).
    pub fn push_owned(&mut self, gid: u64, pos: [f64; D], vel: [f64; D]) {
        debug_assert_eq!(self.n_owned, self.len(), "ghosts must be dropped first");
        self.gid.push(gid);
        self.pos.push(pos);
        self.vel.push(vel);
        self.force.push([0.0; D]);
        self.vel_half.push(vel);
        self.image.push([0; D]);
        if let Some(s) = &mut self.species {
            s.push(0);
        }
        for f in &mut self.extra {
            f.data.extend(std::iter::repeat_n(0.0, f.width));
        }
        for f in &mut self.var {
            f.data.push_empty();
        }
        self.n_owned += 1;
    }

    /// Drops every ghost.
    pub fn clear_ghosts(&mut self) {
        let n = self.n_owned;
        self.gid.truncate(n);
        self.pos.truncate(n);
        self.vel.truncate(n);
        if let Some(s) = &mut self.species {
            s.truncate(n);
        }
        for f in &mut self.extra {
            f.data.truncate(n * f.width);
        }
    }

    /// Appends ghosts in order; their registered fields start at zero (a pass that reads them
    /// asks the halo to refresh them first).
    pub fn push_ghosts(&mut self, ghosts: &[Ghost<D>]) {
        self.gid.extend(ghosts.iter().map(|g| g.gid));
        self.pos.extend(ghosts.iter().map(|g| g.pos));
        self.vel.extend(ghosts.iter().map(|g| g.vel));
        if let Some(s) = &mut self.species {
            s.extend(ghosts.iter().map(|g| g.species));
        }
        for f in &mut self.extra {
            f.data
                .extend(std::iter::repeat_n(0.0, f.width * ghosts.len()));
        }
    }

    /// Appends one ghost (see [`Self::push_ghosts`]).
    pub fn push_ghost(&mut self, gid: u64, pos: [f64; D], vel: [f64; D], species: u8) {
        self.push_ghosts(&[Ghost {
            gid,
            pos,
            vel,
            species,
        }]);
    }

    /// Number of words [`Self::pack_owned`] writes before the variable-length payload.
    fn fixed_record_len(&self) -> usize {
        let migrating: usize = (self.extra.iter())
            .filter(|f| f.flags.migrates)
            .map(|f| f.width)
            .sum();
        1 + 4 * D + D + usize::from(self.species.is_some()) + migrating + self.var.len()
    }

    /// Serialises owned particle `i` with everything that must travel when it migrates (the
    /// fields whose [`FieldFlags::migrates`] is set).
    pub fn pack_owned(&self, i: usize, out: &mut Vec<f64>) {
        out.push(f64::from_bits(self.gid[i]));
        out.extend_from_slice(&self.pos[i]);
        out.extend_from_slice(&self.vel[i]);
        out.extend_from_slice(&self.force[i]);
        out.extend_from_slice(&self.vel_half[i]);
        out.extend(self.image[i].iter().map(|&k| f64::from(k)));
        if let Some(s) = &self.species {
            out.push(f64::from(s[i]));
        }
        for f in self.extra.iter().filter(|f| f.flags.migrates) {
            out.extend_from_slice(&f.data[i * f.width..(i + 1) * f.width]);
        }
        for f in &self.var {
            out.push(f.data.row_len(i) as f64);
        }
        for f in &self.var {
            f.data.extend_f64(i, out);
        }
    }

    /// Appends owned particles from a buffer written by [`Self::pack_owned`] (no ghosts present).
    pub fn unpack_owned(&mut self, buf: &[f64]) {
        debug_assert_eq!(self.n_owned, self.len());
        let mut at = 0;
        let fixed = self.fixed_record_len();
        while at < buf.len() {
            let rec = &buf[at..at + fixed];
            let arr = |k: usize| -> [f64; D] {
                let mut a = [0.0; D];
                a.copy_from_slice(&rec[1 + k * D..1 + (k + 1) * D]);
                a
            };
            self.gid.push(rec[0].to_bits());
            self.pos.push(arr(0));
            self.vel.push(arr(1));
            self.force.push(arr(2));
            self.vel_half.push(arr(3));
            let mut img = [0i32; D];
            for (d, v) in img.iter_mut().enumerate() {
                *v = rec[1 + 4 * D + d] as i32;
            }
            self.image.push(img);
            let mut off = 1 + 5 * D;
            if let Some(s) = &mut self.species {
                s.push(rec[off] as u8);
                off += 1;
            }
            for f in &mut self.extra {
                if f.flags.migrates {
                    f.data.extend_from_slice(&rec[off..off + f.width]);
                    off += f.width;
                } else {
                    // Derived anew before it is next read.
                    f.data.extend(std::iter::repeat_n(0.0, f.width));
                }
            }
            let lens: Vec<usize> = rec[off..off + self.var.len()]
                .iter()
                .map(|&l| l as usize)
                .collect();
            at += fixed;
            for (f, len) in self.var.iter_mut().zip(lens) {
                f.data.push_f64(&buf[at..at + len]);
                at += len;
            }
            self.n_owned += 1;
        }
    }

    /// Reorders the owned particles: new position k holds old particle `order[k]` (no ghosts).
    pub fn permute_owned(&mut self, order: &[u32]) {
        debug_assert_eq!(self.n_owned, self.len());
        debug_assert_eq!(order.len(), self.n_owned);
        // Gathers in the new order on the rayon pool of the caller (the rank's threads), or on
        // the calling thread alone when it is no pool's (never rayon's global pool).
        let on_pool = rayon::current_thread_index().is_some();
        fn apply_to<T: Copy + Send + Sync>(v: &mut Vec<T>, order: &[u32], on_pool: bool) {
            if !on_pool {
                *v = order.iter().map(|&o| v[o as usize]).collect();
                return;
            }
            let mut out = Vec::with_capacity(order.len());
            order
                .par_iter()
                .with_min_len(4096)
                .map(|&o| v[o as usize])
                .collect_into_vec(&mut out);
            *v = out;
        }
        fn apply_wide(v: &mut Vec<f64>, order: &[u32], width: usize, on_pool: bool) {
            let mut out = vec![0.0; v.len()];
            if !on_pool {
                for (dst, &o) in out.chunks_exact_mut(width.max(1)).zip(order) {
                    let o = o as usize;
                    dst.copy_from_slice(&v[o * width..(o + 1) * width]);
                }
                *v = out;
                return;
            }
            out.par_chunks_mut(width.max(1))
                .zip(order.par_iter())
                .with_min_len(1024)
                .for_each(|(dst, &o)| {
                    let o = o as usize;
                    dst.copy_from_slice(&v[o * width..(o + 1) * width]);
                });
            *v = out;
        }
        apply_to(&mut self.gid, order, on_pool);
        apply_to(&mut self.pos, order, on_pool);
        apply_to(&mut self.vel, order, on_pool);
        apply_to(&mut self.force, order, on_pool);
        apply_to(&mut self.vel_half, order, on_pool);
        apply_to(&mut self.image, order, on_pool);
        if let Some(s) = &mut self.species {
            apply_to(s, order, on_pool);
        }
        for f in &mut self.extra {
            apply_wide(&mut f.data, order, f.width, on_pool);
        }
        // Ensembles are moved, not cloned: no second copy of the largest state.
        for f in &mut self.var {
            f.data.permute(order);
        }
    }

    /// Keeps only the owned particles for which `keep` is true (order preserved). Ghosts must
    /// have been dropped.
    pub fn retain_owned(&mut self, keep: &[bool]) {
        debug_assert_eq!(self.n_owned, self.len());
        if keep.iter().all(|&k| k) {
            // The common case between rebuilds: nobody left.
            return;
        }
        fn filter<T: Clone>(v: &mut Vec<T>, keep: &[bool], width: usize) {
            let mut w = 0;
            for (i, &k) in keep.iter().enumerate() {
                if k {
                    for c in 0..width {
                        v.swap(w * width + c, i * width + c);
                    }
                    w += 1;
                }
            }
            v.truncate(w * width);
        }
        filter(&mut self.gid, keep, 1);
        filter(&mut self.pos, keep, 1);
        filter(&mut self.vel, keep, 1);
        filter(&mut self.force, keep, 1);
        filter(&mut self.vel_half, keep, 1);
        filter(&mut self.image, keep, 1);
        if let Some(s) = &mut self.species {
            filter(s, keep, 1);
        }
        for f in &mut self.extra {
            filter(&mut f.data, keep, f.width);
        }
        for f in &mut self.var {
            f.data.retain(keep);
        }
        self.n_owned = self.gid.len();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tensor field holds κ_αβ at row-major position αD + β, whatever nalgebra's own
    /// (column-major) storage.
    #[test]
    fn tensor_fields_are_row_major() {
        let mut p = Particles::<3>::default();
        p.push_owned(0, [0.0; 3], [0.0; 3]);
        let k = p.register_extra("kappa", 9);
        let kappa = Tensor::<3>::new(0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0);
        p.set_tensor(k, 0, &kappa);
        assert_eq!(p.extra[k].data[1], 2.0); // κ_xy
        assert_eq!(p.extra[k].data[8], -1.0); // κ_zz
        assert_eq!(p.tensor(k, 0), kappa);
        assert_eq!(tensor_rows(&kappa)[0][1], 2.0);
    }

    #[test]
    fn pack_unpack_round_trip_with_fields() {
        let mut p = Particles::<3>::default();
        p.register_extra("tensor", 9);
        p.register_var("ensemble");
        for g in 0..4u64 {
            p.push_owned(g + 10, [g as f64, 1.0, 2.0], [0.5, -0.5, g as f64]);
            p.image[g as usize] = [g as i32 - 2, 1, 0];
            let w = p.extra[0].width;
            p.extra[0].data[g as usize * w] = g as f64 * 3.0;
            p.var[0].data.double_mut().unwrap()[g as usize] =
                (0..g).map(|x| x as f64 * 0.1).collect();
        }
        let mut buf = Vec::new();
        for i in [3, 1] {
            p.pack_owned(i, &mut buf);
        }
        let mut q = Particles::<3>::default();
        q.register_extra("tensor", 9);
        q.register_var("ensemble");
        q.unpack_owned(&buf);
        assert_eq!(q.gid, vec![13, 11]);
        assert_eq!(q.image[0], [1, 1, 0]);
        assert_eq!(q.extra[0].data[9], 3.0);
        assert_eq!(q.var[0].data.row_len(0), 3);
        p.retain_owned(&[true, false, true, false]);
        assert_eq!(p.gid, vec![10, 12]);
        assert_eq!(p.var[0].data.row_len(1), 2);
        assert_eq!(p.extra[0].data[9], 6.0);
    }
}
