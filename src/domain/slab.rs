//! Slab ownership along one axis.

/// Rank `r` of `P` owns `[L r / P, L (r+1) / P)` along `axis`.
#[derive(Clone, Debug)]
pub struct Slab {
    /// Decomposed axis.
    pub axis: usize,
    /// Box length along the axis.
    pub length: f64,
    /// This rank.
    pub rank: usize,
    /// Number of ranks.
    pub size: usize,
    /// Whether the axis is periodic (the first and last slab are neighbours).
    pub periodic: bool,
}

impl Slab {
    /// Lower bound of rank `r`'s slab.
    pub fn lo_of(&self, r: usize) -> f64 {
        self.length * r as f64 / self.size as f64
    }

    /// This rank's lower bound.
    pub fn lo(&self) -> f64 {
        self.lo_of(self.rank)
    }

    /// This rank's upper bound.
    pub fn hi(&self) -> f64 {
        self.lo_of(self.rank + 1)
    }

    /// Slab width.
    pub fn width(&self) -> f64 {
        self.length / self.size as f64
    }

    /// Rank above (periodic ring).
    pub fn up(&self) -> usize {
        (self.rank + 1) % self.size
    }

    /// Rank below (periodic ring).
    pub fn down(&self) -> usize {
        (self.rank + self.size - 1) % self.size
    }

    /// Owner of coordinate `x ∈ [0, L)`, consistent with [`Self::lo_of`] bit for bit.
    pub fn owner_of(&self, x: f64) -> usize {
        let mut r = ((x / self.length) * self.size as f64).floor().max(0.0) as usize;
        r = r.min(self.size - 1);
        while r > 0 && x < self.lo_of(r) {
            r -= 1;
        }
        while r + 1 < self.size && x >= self.lo_of(r + 1) {
            r += 1;
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn owner_agrees_with_bounds() {
        for size in 1..7 {
            let s = Slab {
                axis: 1,
                length: 7.3,
                rank: 0,
                size,
                periodic: true,
            };
            for k in 0..1000 {
                let x = 7.3 * k as f64 / 1000.0;
                let r = s.owner_of(x);
                assert!(s.lo_of(r) <= x && x < s.lo_of(r + 1), "x={x} r={r}");
            }
        }
    }
}
