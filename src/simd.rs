//! Run-time choice of the vector instruction set for the hot loops.
//!
//! The pair loops and the neighbour-list build are compiled twice: portable (SSE2 on x86-64) and
//! with AVX2 enabled, chosen per run by what the CPU reports; the SPH momentum sums gathered in
//! lanes (`models::sph::lanes`) also with AVX-512. FMA is never enabled, and Rust never
//! contracts a·b + c into one rounding, so every version performs the same IEEE operations and
//! gives the same bits (unit tests in `models::pair_loop` and `models::sph` compare them); the
//! AVX2 one does four doubles per instruction where the compiler vectorises, the AVX-512 one
//! eight.
//!
//! `MESORHEO_SIMD=portable` or `MESORHEO_SIMD=avx2` in the environment caps the instruction set
//! (for comparisons, or a CPU that misreports its features).

use std::sync::OnceLock;

/// An instruction set the hot loops may use. A value asking for AVX2 exists only when the CPU
/// has it, which is what makes calling the AVX2 versions sound.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Isa {
    avx2: bool,
    avx512: bool,
}

impl Isa {
    /// The baseline of the target (SSE2 on x86-64).
    pub const PORTABLE: Self = Self {
        avx2: false,
        avx512: false,
    };

    /// AVX2, if this CPU has it.
    pub fn avx2() -> Option<Self> {
        detected().then_some(Self {
            avx2: true,
            avx512: false,
        })
    }

    /// AVX-512 (F, VL, DQ, BW, CD) and AVX2, if this CPU has them: the loops written for eight
    /// lanes ([`crate::models::gather::LANES`]) use it; every other loop takes its AVX2 version.
    pub fn avx512() -> Option<Self> {
        (detected() && detected_avx512()).then_some(Self {
            avx2: true,
            avx512: true,
        })
    }

    /// What this process uses: the widest of AVX-512 and AVX2 the CPU has, unless
    /// `MESORHEO_SIMD` is `portable` or `avx2` (decided once).
    pub fn current() -> Self {
        static CHOICE: OnceLock<Isa> = OnceLock::new();
        *CHOICE.get_or_init(|| match std::env::var("MESORHEO_SIMD").as_deref() {
            Ok("portable") => Self::PORTABLE,
            Ok("avx2") => Self::avx2().unwrap_or(Self::PORTABLE),
            _ => Self::avx512().or_else(Self::avx2).unwrap_or(Self::PORTABLE),
        })
    }

    /// AVX2 for a test that compares it with the portable version; without it, says on the
    /// test run's own stderr (not captured, so it shows in every log) that `test` is skipped.
    pub fn avx2_for_test(test: &str) -> Option<Self> {
        let isa = Self::avx2();
        if isa.is_none() {
            use std::io::Write as _;
            let _ = writeln!(
                std::io::stderr(),
                "SKIPPED {test}: this CPU has no AVX2, so only the portable version is tested"
            );
        }
        isa
    }

    /// Whether the AVX2 versions run (only ever true on a CPU that has AVX2).
    pub fn has_avx2(self) -> bool {
        self.avx2
    }

    /// Whether the AVX-512 versions run (only ever true on a CPU that has the AVX-512 subsets
    /// [`Self::avx512`] names).
    pub fn has_avx512(self) -> bool {
        self.avx512
    }
}

#[cfg(target_arch = "x86_64")]
fn detected() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

#[cfg(not(target_arch = "x86_64"))]
fn detected() -> bool {
    false
}

#[cfg(target_arch = "x86_64")]
fn detected_avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx512dq")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512cd")
}

#[cfg(not(target_arch = "x86_64"))]
fn detected_avx512() -> bool {
    false
}
