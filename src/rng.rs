//! Counter-based random numbers: Philox4x32-10 (Salmon et al., SC'11 "Parallel random numbers:
//! as easy as 1, 2, 3"), the generator behind Random123 and HOOMD-blue.
//!
//! A random number is a pure function of a key and a counter, so a draw depends only on *what*
//! it is for — `(seed, purpose, step, ids)` — and never on which rank or thread evaluates it.
//! That is what makes trajectories bitwise identical for any decomposition (docs/architecture.md,
//! "Determinism"). No generator state exists, so a checkpoint needs none.
//!
//! Layout of one draw:
//! - key `= [seed_lo, seed_hi]` (the case's 64-bit seed),
//! - counter `= [step (low 32 bits), purpose << 24 | stage, id_a, id_b]`.
//!
//! Pair noise uses `(id_a, id_b) = (min gid, max gid)` so θ_ij = θ_ji on every rank.

/// What a draw is used for; each purpose gets disjoint counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Purpose {
    /// DPD pair noise θ_ij.
    DpdPair = 1,
    /// Initial Maxwellian velocities.
    InitialVelocity = 2,
    /// Random initial positions.
    InitialPosition = 3,
    /// Brownian noise of dumbbell ensembles (keyed by particle id and step).
    DumbbellNoise = 4,
    /// Equilibrium initial state of dumbbell ensembles.
    DumbbellInit = 5,
    /// Test-only uses.
    Test = 255,
}

const PHILOX_M0: u32 = 0xD251_1F53;
const PHILOX_M1: u32 = 0xCD9E_8D57;
const PHILOX_W0: u32 = 0x9E37_79B9;
const PHILOX_W1: u32 = 0xBB67_AE85;

#[inline(always)]
fn mulhilo(a: u32, b: u32) -> (u32, u32) {
    let p = u64::from(a) * u64::from(b);
    ((p >> 32) as u32, p as u32)
}

#[inline(always)]
fn philox_round(ctr: [u32; 4], key: [u32; 2]) -> [u32; 4] {
    let (hi0, lo0) = mulhilo(PHILOX_M0, ctr[0]);
    let (hi1, lo1) = mulhilo(PHILOX_M1, ctr[2]);
    [hi1 ^ ctr[1] ^ key[0], lo1, hi0 ^ ctr[3] ^ key[1], lo0]
}

/// Philox4x32 with 10 rounds: the bijection `ctr ↦ out` selected by `key`.
#[inline]
pub fn philox4x32_10(mut ctr: [u32; 4], mut key: [u32; 2]) -> [u32; 4] {
    for round in 0..10 {
        if round > 0 {
            key[0] = key[0].wrapping_add(PHILOX_W0);
            key[1] = key[1].wrapping_add(PHILOX_W1);
        }
        ctr = philox_round(ctr, key);
    }
    ctr
}

/// Key of a draw: everything that identifies *what* the number is for.
#[derive(Clone, Copy, Debug)]
pub struct StreamKey {
    key: [u32; 2],
    purpose_stage: u32,
}

impl StreamKey {
    /// A stream for `purpose` under the case seed; `stage` distinguishes sub-steps.
    pub fn new(seed: u64, purpose: Purpose, stage: u8) -> Self {
        Self {
            key: [seed as u32, (seed >> 32) as u32],
            purpose_stage: ((purpose as u32) << 24) | u32::from(stage),
        }
    }

    /// Four 32-bit words for `(step, a, b)`.
    #[inline]
    pub fn words(&self, step: u64, a: u32, b: u32) -> [u32; 4] {
        philox4x32_10([step as u32, self.purpose_stage, a, b], self.key)
    }

    /// Two uniform numbers in the open interval (0, 1) with 53 random bits each.
    #[inline]
    pub fn uniform2(&self, step: u64, a: u32, b: u32) -> (f64, f64) {
        let w = self.words(step, a, b);
        let u0 = (u64::from(w[0]) << 32) | u64::from(w[1]);
        let u1 = (u64::from(w[2]) << 32) | u64::from(w[3]);
        (open_unit(u0), open_unit(u1))
    }

    /// One standard normal number (Box–Muller, cosine branch).
    #[inline]
    pub fn gaussian(&self, step: u64, a: u32, b: u32) -> f64 {
        let (u0, u1) = self.uniform2(step, a, b);
        box_muller(u0, u1).0
    }

    /// Two independent standard normal numbers.
    #[inline]
    pub fn gaussian2(&self, step: u64, a: u32, b: u32) -> (f64, f64) {
        let (u0, u1) = self.uniform2(step, a, b);
        box_muller(u0, u1)
    }

    /// A uniform number with zero mean and unit variance: √3 (2u − 1).
    #[inline]
    pub fn unit_variance_uniform(&self, step: u64, a: u32, b: u32) -> f64 {
        let w = self.words(step, a, b);
        let u = open_unit((u64::from(w[0]) << 32) | u64::from(w[1]));
        SQRT_3 * (2.0 * u - 1.0)
    }
}

const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// Maps 64 random bits to (0, 1): the top 53 bits plus one half ulp, never 0 or 1.
#[inline(always)]
pub fn open_unit(bits: u64) -> f64 {
    ((bits >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
}

/// Box–Muller transform of two uniforms in (0, 1).
#[inline(always)]
pub fn box_muller(u0: f64, u1: f64) -> (f64, f64) {
    let radius = (-2.0 * u0.ln()).sqrt();
    let (s, c) = (std::f64::consts::TAU * u1).sin_cos();
    (radius * c, radius * s)
}

/// SplitMix64's finaliser (Stafford's mix 13): a bijection of u64 with full avalanche.
#[inline(always)]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// A cheap keyed stream for the hot pair-noise path (the SplitMix/Saru style HOOMD uses for DPD,
/// docs/architecture.md): the key words are folded through [`mix64`] into a start value, then
/// SplitMix64 runs from there. About 2 ns per number instead of ~16 ns for a Philox block; its
/// statistics are tested below (moments, tails, correlations between neighbouring keys, steps and
/// ids).
#[derive(Clone, Copy, Debug)]
pub struct HashStream {
    state: u64,
}

impl HashStream {
    /// The stream for `(seed, purpose, step, a, b)`.
    #[inline(always)]
    pub fn new(seed: u64, purpose: Purpose, step: u64, a: u64, b: u64) -> Self {
        Self::from_prefix(Self::prefix(seed, purpose, step), a, b)
    }

    /// The part of the start value that depends on `(seed, purpose, step)` only: computed
    /// once per step, it is finished per pair by [`Self::from_prefix`] (the same bits as
    /// [`Self::new`]).
    #[inline(always)]
    pub fn prefix(seed: u64, purpose: Purpose, step: u64) -> u64 {
        let h = mix64(seed ^ ((purpose as u64) << 56) ^ GOLDEN);
        mix64(h ^ step.wrapping_mul(0xD6E8_FEB8_6659_FD93))
    }

    /// The stream for `(a, b)` under a [`Self::prefix`].
    #[inline(always)]
    pub fn from_prefix(prefix: u64, a: u64, b: u64) -> Self {
        let mut h = mix64(prefix ^ a.wrapping_mul(GOLDEN));
        h = mix64(h ^ b.wrapping_mul(0xCA5A_8263_9512_1157));
        Self { state: h }
    }

    /// Next 64 random bits.
    #[inline(always)]
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GOLDEN);
        mix64(self.state)
    }

    /// Uniform in (0, 1).
    #[inline(always)]
    pub fn uniform(&mut self) -> f64 {
        open_unit(self.next_u64())
    }

    /// Standard normal by the ziggurat method (Marsaglia & Tsang, J. Stat. Softw. 5 (2000);
    /// 256 layers, as in Doornik's and rand_distr's variants): one 64-bit draw in ~99 % of calls.
    #[inline]
    pub fn normal(&mut self) -> f64 {
        self.normal_with(ziggurat())
    }

    /// Fills `out` with standard normals — the same numbers, in the same order, as `out.len()`
    /// calls of [`Self::normal`] — with the ziggurat table looked up once.
    pub fn fill_normals(&mut self, out: &mut [f64]) {
        let z = ziggurat();
        for o in out {
            *o = self.normal_with(z);
        }
    }

    #[inline(always)]
    fn normal_with(&mut self, z: &Ziggurat) -> f64 {
        let bits = self.next_u64();
        let i = (bits & 0xff) as usize;
        // 52 bits → u ∈ (−1, 1)
        let u = 2.0 * (((bits >> 12) as f64 + 0.5) * (1.0 / (1u64 << 52) as f64)) - 1.0;
        let x = u * z.x[i];
        if x.abs() < z.x[i + 1] {
            return x;
        }
        self.normal_slow(z, i, u, x)
    }

    /// The ziggurat's rare paths (base strip tail, wedges), then the retry loop.
    #[cold]
    #[inline(never)]
    fn normal_slow(&mut self, z: &Ziggurat, mut i: usize, mut u: f64, mut x: f64) -> f64 {
        loop {
            if i == 0 {
                // Tail beyond R (Marsaglia 1964).
                loop {
                    let xt = self.uniform().ln() / ZIG_R;
                    let yt = self.uniform().ln();
                    if -2.0 * yt >= xt * xt {
                        return if u < 0.0 { xt - ZIG_R } else { ZIG_R - xt };
                    }
                }
            }
            if z.f[i + 1] + (z.f[i] - z.f[i + 1]) * self.uniform() < (-0.5 * x * x).exp() {
                return x;
            }
            let bits = self.next_u64();
            i = (bits & 0xff) as usize;
            u = 2.0 * (((bits >> 12) as f64 + 0.5) * (1.0 / (1u64 << 52) as f64)) - 1.0;
            x = u * z.x[i];
            if x.abs() < z.x[i + 1] {
                return x;
            }
        }
    }
}

/// A fast sequential stream of standard normals behind a counter-based key, for the dumbbell
/// ensembles (docs/architecture.md, "Determinism" item 1: one fast stream per (particle, step)).
///
/// - Key: the [`HashStream`] of `(seed, purpose, step, a, b)` (keyed SplitMix64) produces the
///   four state words, so the stream is a pure function of its key — no state to checkpoint,
///   the same numbers on any rank or thread. SplitMix64 outputs are the seeding Blackman & Vigna
///   recommend; they are distinct (SplitMix64 is a bijection of distinct counters), so the
///   state is never all zero.
/// - Generator: xoshiro256++ (Blackman & Vigna, ACM TOMS 47 (2021) 36), period 2²⁵⁶ − 1, no
///   multiplication on the critical path.
/// - Normals: the same 256-layer ziggurat as [`HashStream::normal`] (Marsaglia & Tsang 2000),
///   with the layer table a `static` (no initialisation check per call) and one 64-bit draw per
///   normal in ~99 % of the calls: 8 bits choose the layer, the top 52 bits give u ∈ (−1, 1)
///   (built by writing them into the mantissa of a float in [2, 4): no integer→float
///   conversion). The rare paths (wedges, tail beyond R) are out of line, on a side stream
///   (see `normal_slow`), so the hot loop keeps the xoshiro state in registers.
///
/// Statistics are tested below (moments, tails, χ² of the histogram, lag-1 and neighbouring-key
/// correlations). Generator alone ≈ 1.3× [`HashStream::fill_normals`] (2.4–2.9 ns per normal
/// against ~3.1 ns, best repetitions on a loaded machine; docs/performance.md); the bits differ
/// from [`HashStream`]'s (the DPD pair noise keeps that one, digests pinned).
#[derive(Clone, Debug)]
pub struct NormalStream {
    s: [u64; 4],
}

impl NormalStream {
    /// The stream for `(seed, purpose, step, a, b)`.
    #[inline]
    pub fn new(seed: u64, purpose: Purpose, step: u64, a: u64, b: u64) -> Self {
        let mut key = HashStream::new(seed, purpose, step, a, b);
        Self {
            s: [
                key.next_u64(),
                key.next_u64(),
                key.next_u64(),
                key.next_u64(),
            ],
        }
    }

    /// Next 64 random bits (xoshiro256++).
    #[inline(always)]
    pub fn next_u64(&mut self) -> u64 {
        xoshiro256pp(&mut self.s)
    }

    /// Uniform in (0, 1).
    #[inline(always)]
    pub fn uniform(&mut self) -> f64 {
        open_unit(self.next_u64())
    }

    /// One standard normal (ziggurat; see the type's documentation).
    #[inline]
    pub fn normal(&mut self) -> f64 {
        normal_from(&mut self.s)
    }

    /// Fills `out` with standard normals: the numbers of `out.len()` calls of [`Self::normal`].
    pub fn fill_normals(&mut self, out: &mut [f64]) {
        let mut s = self.s;
        for o in out {
            *o = normal_from(&mut s);
        }
        self.s = s;
    }
}

/// One xoshiro256++ step on the state `s` (Blackman & Vigna's reference code).
#[inline(always)]
fn xoshiro256pp(s: &mut [u64; 4]) -> u64 {
    let out = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
    let t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = s[3].rotate_left(45);
    out
}

/// One ziggurat normal from the xoshiro256++ state `s`.
#[inline(always)]
fn normal_from(s: &mut [u64; 4]) -> f64 {
    let bits = xoshiro256pp(s);
    let (i, u) = ziggurat_layer_and_u(bits);
    let x = u * ZIG_X[i];
    if x.abs() < ZIG_X[i + 1] {
        return x;
    }
    normal_slow(bits, i, u, x)
}

/// The ziggurat's rare paths (~1 % of the draws: base strip tail, wedges, retries). Their extra
/// random numbers come from a SplitMix64 side stream started at a hash of the rejected draw's 64
/// bits, not from the xoshiro state: so the hot loop never passes its state to a call and keeps
/// it in registers. The side stream is a pure function of the main stream (determinism kept)
/// and, the hash being a bijection with full avalanche, independent of the layer and u that the
/// rejected bits encoded (tested: tails beyond 3, R and 4, χ² of the histogram).
#[cold]
#[inline(never)]
fn normal_slow(bits: u64, mut i: usize, mut u: f64, mut x: f64) -> f64 {
    let mut side = HashStream {
        state: mix64(bits ^ 0x5851_F42D_4C95_7F2D),
    };
    loop {
        if i == 0 {
            // Tail beyond R (Marsaglia 1964).
            loop {
                let xt = side.uniform().ln() / ZIG_R;
                let yt = side.uniform().ln();
                if -2.0 * yt >= xt * xt {
                    return if u < 0.0 { xt - ZIG_R } else { ZIG_R - xt };
                }
            }
        }
        if ZIG_F[i + 1] + (ZIG_F[i] - ZIG_F[i + 1]) * side.uniform() < (-0.5 * x * x).exp() {
            return x;
        }
        (i, u) = ziggurat_layer_and_u(side.next_u64());
        x = u * ZIG_X[i];
        if x.abs() < ZIG_X[i + 1] {
            return x;
        }
    }
}

/// Layer (low 8 bits) and u ∈ (−1, 1) (top 52 bits) of one 64-bit draw: the 52 bits are the
/// mantissa of v ∈ [2, 4), so u = v − 3 + 2⁻⁵² takes the 2⁵² odd multiples of 2⁻⁵² in (−1, 1)
/// with equal probability: symmetric about 0, never 0, every step exact in floating point.
#[inline(always)]
fn ziggurat_layer_and_u(bits: u64) -> (usize, f64) {
    const TWO: u64 = 0x4000_0000_0000_0000; // 2.0
    let v = f64::from_bits((bits >> 12) | TWO);
    ((bits & 0xff) as usize, (v - 3.0) + f64::EPSILON)
}

// The ziggurat layer boundaries x_i and densities f_i = exp(−x_i²/2) of the 256-layer table
// (R and V below; x_0 = V/f(R) is the base strip's pseudo-width), as computed by `ziggurat()`
// (the test `static_ziggurat_table_matches_its_formula` checks every entry).
static ZIG_X: [f64; ZIG_LAYERS + 1] = [
    3.91075795953709,
    3.654152885361009,
    3.4492782985609645,
    3.320244733839166,
    3.224575052047029,
    3.14788928951715,
    3.083526132001233,
    3.0278377917686354,
    2.978603279880845,
    2.9343668672078542,
    2.894121053612348,
    2.8571387308721325,
    2.822877396825325,
    2.7909211740007858,
    2.7609440052788226,
    2.732685359042827,
    2.705933656121858,
    2.680514643284522,
    2.6562830375755024,
    2.6331163936303246,
    2.6109105184875485,
    2.589575986706995,
    2.5690354526805366,
    2.5492215503234608,
    2.530075232158517,
    2.5115444416253423,
    2.4935830412696807,
    2.4761499396691433,
    2.4592083743333113,
    2.4427253181989568,
    2.426670984935726,
    2.4110184138996855,
    2.3957431197804806,
    2.380822795170626,
    2.3662370567158186,
    2.35196722737766,
    2.3379961487950314,
    2.324308018869623,
    2.31088825059985,
    2.2977233489013296,
    2.284800802722946,
    2.272108990226824,
    2.259637095172218,
    2.2473750329458078,
    2.235313384928328,
    2.2234433400909057,
    2.2117566428825444,
    2.200245546609648,
    2.1889027716247207,
    2.1777214677386416,
    2.166695180352646,
    2.1558178198750633,
    2.1450836340462036,
    2.13448718284432,
    2.1240233156878157,
    2.113687150684934,
    2.103474055713147,
    2.0933796311370503,
    2.083399693996552,
    2.0735302635169788,
    2.0637675478099564,
    2.054107931648865,
    2.044547965215733,
    2.0350843537278087,
    2.025713947862033,
    2.0164337349043717,
    2.007240830558685,
    1.9981324713565642,
    1.9891060076155713,
    1.9801588968985984,
    1.9712886979317696,
    1.962493064942462,
    1.953769742382734,
    1.945116560006754,
    1.936531428273759,
    1.9280123340507183,
    1.9195573365912288,
    1.9111645637692822,
    1.9028322085484464,
    1.89455852566871,
    1.8863418285347764,
    1.8781804862909777,
    1.8700729210692368,
    1.8620176053976323,
    1.8540130597581481,
    1.8460578502831198,
    1.8381505865807286,
    1.8302899196806666,
    1.8224745400917832,
    1.8147031759641676,
    1.8069745913486934,
    1.7992875845475802,
    1.79164098655001,
    1.7840336595472763,
    1.776464495522345,
    1.768932414909078,
    1.7614363653167067,
    1.753975320315455,
    1.746548278279493,
    1.739154261283669,
    1.7317923140507072,
    1.7244615029457757,
    1.7171609150155407,
    1.709889657069006,
    1.702646854797614,
    1.6954316519322385,
    1.6882432094348587,
    1.6810807047228233,
    1.6739433309237604,
    1.6668302961592867,
    1.6597408228557895,
    1.6526741470806485,
    1.6456295179023603,
    1.6386061967731111,
    1.631603456932422,
    1.6246205828305684,
    1.6176568695705342,
    1.6107116223673337,
    1.603784156023583,
    1.5968737944202613,
    1.5899798700216485,
    1.5831017233934714,
    1.5762387027333329,
    1.5693901634125345,
    1.5625554675284397,
    1.555733983466555,
    1.5489250854715355,
    1.5421281532263476,
    1.5353425714388431,
    1.5285677294350246,
    1.521803020758293,
    1.5150478427739924,
    1.508301596278572,
    1.5015636851127065,
    1.4948335157777184,
    1.4881104970546544,
    1.4813940396253757,
    1.4746835556950255,
    1.467978458615231,
    1.4612781625074078,
    1.4545820818855233,
    1.4478896312776697,
    1.441200224845798,
    1.4345132760029464,
    1.4278281970272904,
    1.4211443986723231,
    1.4144612897724647,
    1.4077782768433715,
    1.4010947636762026,
    1.3944101509250713,
    1.3877238356868846,
    1.381035211072742,
    1.3743436657700305,
    1.367648583594318,
    1.3609493430301018,
    1.3542453167594306,
    1.3475358711773593,
    1.3408203658931521,
    1.3340981532160836,
    1.3273685776246247,
    1.32063097521773,
    1.313884673146869,
    1.3071289890273539,
    1.3003632303274337,
    1.2935866937335176,
    1.2867986644897864,
    1.2799984157103332,
    1.2731852076618437,
    1.2663582870146883,
    1.2595168860601442,
    1.2526602218912979,
    1.245787495544998,
    1.2388978911020274,
    1.231990574742445,
    1.225064693752808,
    1.2181193754817266,
    1.2111537262399112,
    1.2041668301405601,
    1.197157747875586,
    1.1901255154228016,
    1.1830691426787607,
    1.1759876120114898,
    1.1688798767268338,
    1.1617448594415742,
    1.1545814503558518,
    1.1473885054167339,
    1.1401648443639958,
    1.132909248648337,
    1.1256204592112944,
    1.118297174115063,
    1.1109380460092495,
    1.1035416794202682,
    1.0961066278476035,
    1.0886313906495142,
    1.0811144096988894,
    1.0735540657878717,
    1.0659486747575067,
    1.0582964833260065,
    1.0505956645862071,
    1.0428443131393705,
    1.0350404398286053,
    1.0271819660307513,
    1.0192667174605292,
    1.0112924174349784,
    1.0032566795395914,
    0.9951569996299431,
    0.9869907470938463,
    0.9787551552889378,
    0.9704473110588646,
    0.9620641432176052,
    0.9536024098755727,
    0.9450586844625711,
    0.9364293402808969,
    0.9277105333962348,
    0.918898183643735,
    0.909987953490769,
    0.9009752244551745,
    0.8918550707267924,
    0.8826222295789101,
    0.8732710680824946,
    0.8637955455468269,
    0.8541891710015606,
    0.8444449549024237,
    0.8345553540795188,
    0.8245122087452886,
    0.8143066701280643,
    0.8039291169826649,
    0.7933690588331528,
    0.7826150232995888,
    0.7716544242167394,
    0.7604734064220832,
    0.7490566620095817,
    0.7373872114258386,
    0.7254461409013035,
    0.7132122851820227,
    0.7006618410975844,
    0.6877678927862577,
    0.6744998228274365,
    0.660822574234206,
    0.6466957148843889,
    0.6320722363750246,
    0.6168969899962355,
    0.6011046177439404,
    0.5846167660937223,
    0.567338257040473,
    0.5491517023130268,
    0.5299097206464951,
    0.5094233295859334,
    0.48744396612175434,
    0.46363433677176324,
    0.43751840218666266,
    0.40838913458800075,
    0.3751213328504657,
    0.33573751918045946,
    0.2861745917472605,
    0.2152418959132738,
    0.0,
];
static ZIG_F: [f64; ZIG_LAYERS + 1] = [
    0.0004774677645866553,
    0.001260285930498598,
    0.002609072746106363,
    0.0040379725933718715,
    0.005522403299264754,
    0.00705087547139211,
    0.008616582769422917,
    0.0102149714397311,
    0.011842757857943104,
    0.013497450601780807,
    0.015177088307982072,
    0.01688008315259584,
    0.01860512127578335,
    0.020351096230109354,
    0.022117062707379922,
    0.023902203305873237,
    0.025705804008632656,
    0.027527235669693315,
    0.02936593975823011,
    0.03122141719202369,
    0.0330932194586887,
    0.03498094146183307,
    0.03688421568869115,
    0.03880270740465692,
    0.04073611065607875,
    0.04268414491661938,
    0.044646552251446536,
    0.046623094902089664,
    0.048613553216035145,
    0.05061772386112179,
    0.05263541827697365,
    0.054666461325077916,
    0.05671069010639947,
    0.058767952921137984,
    0.060838108349751806,
    0.06292102443797785,
    0.06501657797147044,
    0.06712465382802399,
    0.06924514439725027,
    0.07137794905914197,
    0.07352297371424099,
    0.07568013035919496,
    0.07784933670237221,
    0.08003051581494751,
    0.08222359581349568,
    0.08442850957065466,
    0.08664519445086778,
    0.08887359206859423,
    0.09111364806670073,
    0.09336531191302662,
    0.09562853671335333,
    0.09790327903921563,
    0.10018949876917202,
    0.10248715894230627,
    0.10479622562286706,
    0.10711666777507288,
    0.10944845714721002,
    0.11179156816424558,
    0.11414597782825521,
    0.11651166562603701,
    0.1188886134433457,
    0.12127680548523544,
    0.1236762282020514,
    0.12608687022065035,
    0.12850872228047364,
    0.13094177717412817,
    0.13338602969216284,
    0.13584147657175735,
    0.13830811644906432,
    0.1407859498149683,
    0.14327497897404712,
    0.14577520800653793,
    0.14828664273312872,
    0.15080929068241017,
    0.15334316106083767,
    0.15588826472506456,
    0.15844461415652022,
    0.16101222343811766,
    0.16359110823298295,
    0.16618128576511007,
    0.16878277480185033,
    0.17139559563815562,
    0.17401977008249936,
    0.17665532144440665,
    0.1793022745235304,
    0.1819606556002165,
    0.18463049242750454,
    0.18731181422451693,
    0.19000465167119307,
    0.1927090369043288,
    0.1954250035148856,
    0.1981525865465381,
    0.20089182249543133,
    0.2036427493111215,
    0.20640540639867933,
    0.20917983462193565,
    0.21196607630785294,
    0.2147641752520085,
    0.21757417672517837,
    0.2203961274810116,
    0.2232300757647896,
    0.22607607132326488,
    0.22893416541557748,
    0.23180441082524852,
    0.2346868618732527,
    0.23758157443217368,
    0.2404886059414491,
    0.243408015423712,
    0.24633986350223877,
    0.2492842124195167,
    0.25224112605694377,
    0.25521066995567715,
    0.258192911338648,
    0.2611879191337637,
    0.26419576399831757,
    0.26721651834463184,
    0.27025025636696,
    0.2732970540696758,
    0.27635698929678126,
    0.2794301417627653,
    0.2825165930848494,
    0.2856164268166581,
    0.28872972848335393,
    0.291856585618281,
    0.29499708780116257,
    0.29815132669790134,
    0.3013193961020341,
    0.3045013919778963,
    0.30769741250555377,
    0.3109075581275637,
    0.31413193159763014,
    0.3173706380312224,
    0.32062378495823013,
    0.323891482377732,
    0.3271738428149586,
    0.3304709813805371,
    0.3337830158321085,
    0.3371100666384128,
    0.34045225704594545,
    0.34380971314829134,
    0.3471825639582515,
    0.3505709414828812,
    0.35397498080156925,
    0.3573948201472905,
    0.36083060099117575,
    0.3642824681305496,
    0.3677505697805962,
    0.37123505766982134,
    0.3747360871394914,
    0.3782538172472381,
    0.38178841087503135,
    0.38534003484173396,
    0.3889088600204646,
    0.39249506146101076,
    0.3960988185175471,
    0.39972031498193167,
    0.4033597392228689,
    0.40701728433124795,
    0.4106931482719832,
    0.4143875340427068,
    0.4181006498396846,
    0.4218327092313533,
    0.4255839313399006,
    0.4293545410313415,
    0.43314476911457406,
    0.4369548525499293,
    0.4407850346677699,
    0.44463556539772775,
    0.44850670150921407,
    0.4523987068638825,
    0.45631185268077357,
    0.4602464178149235,
    0.46420268905027884,
    0.46818096140782217,
    0.47218153846988326,
    0.4762047327216838,
    0.4802508659112497,
    0.4843202694289116,
    0.48841328470771206,
    0.49253026364614866,
    0.4966715690547963,
    0.5008375751284821,
    0.5050286679458288,
    0.5092452459981361,
    0.513487720749743,
    0.5177565172322006,
    0.5220520746747949,
    0.5263748471741867,
    0.5307253044061939,
    0.5351039323830196,
    0.5395112342595446,
    0.5439477311926499,
    0.5484139632579211,
    0.5529104904285199,
    0.5574378936214863,
    0.5619967758172779,
    0.5665877632589518,
    0.571211506738075,
    0.5758686829752105,
    0.5805599961036835,
    0.5852861792663003,
    0.590047996335792,
    0.5948462437709913,
    0.5996817526221677,
    0.6045553907005495,
    0.6094680649288954,
    0.6144207238920768,
    0.6194143606090392,
    0.6244500155502742,
    0.6295287799281283,
    0.63465179929096,
    0.639820277456439,
    0.6450354808242519,
    0.6502987431142946,
    0.6556114705832247,
    0.6609751477802414,
    0.6663913439123806,
    0.6718617199007664,
    0.6773880362225131,
    0.6829721616487914,
    0.6886160830085271,
    0.6943219161300326,
    0.7000919181404901,
    0.7059285013367974,
    0.7118342488823585,
    0.7178119326349014,
    0.7238645334728816,
    0.7299952645658024,
    0.7362075981312667,
    0.7425052963446362,
    0.7488924472237267,
    0.7553735065117545,
    0.7619533468415465,
    0.7686373158033348,
    0.7754313049861383,
    0.7823418326598619,
    0.7893761435711986,
    0.7965423304282546,
    0.8038494831763895,
    0.8113078743182199,
    0.8189291916094148,
    0.8267268339520942,
    0.8347162929929304,
    0.8429156531184411,
    0.8513462584651237,
    0.8600336212030086,
    0.8690086880437932,
    0.8783096558161468,
    0.8879846607633999,
    0.898095921906304,
    0.9087264400605629,
    0.9199915050483602,
    0.9320600759689902,
    0.945198953453078,
    0.9598790918124159,
    0.9771017012827313,
    1.0,
];

const ZIG_LAYERS: usize = 256;
const ZIG_R: f64 = 3.654_152_885_361_009;
const ZIG_V: f64 = 0.004_928_673_233_99;

struct Ziggurat {
    x: [f64; ZIG_LAYERS + 1],
    f: [f64; ZIG_LAYERS + 1],
}

fn ziggurat() -> &'static Ziggurat {
    static TABLE: std::sync::OnceLock<Ziggurat> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let pdf = |x: f64| (-0.5 * x * x).exp();
        let mut x = [0.0; ZIG_LAYERS + 1];
        x[0] = ZIG_V / pdf(ZIG_R);
        x[1] = ZIG_R;
        for i in 1..ZIG_LAYERS - 1 {
            x[i + 1] = (-2.0 * (ZIG_V / x[i] + pdf(x[i])).ln()).sqrt();
        }
        x[ZIG_LAYERS] = 0.0;
        let mut f = [0.0; ZIG_LAYERS + 1];
        for i in 0..=ZIG_LAYERS {
            f[i] = pdf(x[i]);
        }
        Ziggurat { x, f }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_normals_gives_the_numbers_of_repeated_normal_calls() {
        for key in 0..50u64 {
            let mut a = HashStream::new(3, Purpose::Test, key, 1, 2);
            let mut b = a;
            let mut buf = vec![0.0; 4000];
            a.fill_normals(&mut buf);
            for (k, x) in buf.iter().enumerate() {
                assert_eq!(x.to_bits(), b.normal().to_bits(), "key {key} draw {k}");
            }
        }
    }

    /// Known-answer vectors of Random123 (`tests/kat_vectors`, philox4x32 10 rounds).
    #[test]
    fn philox_matches_random123_known_answers() {
        assert_eq!(
            philox4x32_10([0, 0, 0, 0], [0, 0]),
            [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8]
        );
        assert_eq!(
            philox4x32_10([u32::MAX; 4], [u32::MAX; 2]),
            [0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd]
        );
        assert_eq!(
            philox4x32_10(
                [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
                [0xa4093822, 0x299f31d0]
            ),
            [0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1]
        );
    }

    /// Moments of the Gaussian stream over 4·10⁵ keyed draws: mean, variance, 4th moment
    /// within 5 standard errors of N(0, 1) (σ of the sample mean is 1/√n, of the variance √(2/n),
    /// of the 4th moment √(96/n)).
    #[test]
    fn gaussian_moments() {
        let key = StreamKey::new(12345, Purpose::Test, 0);
        let n = 400_000u32;
        let (mut m1, mut m2, mut m4) = (0.0, 0.0, 0.0);
        for i in 0..n {
            let g = key.gaussian(7, i, i.wrapping_mul(2_654_435_761));
            m1 += g;
            m2 += g * g;
            m4 += g * g * g * g;
        }
        let nf = f64::from(n);
        let (m1, m2, m4) = (m1 / nf, m2 / nf, m4 / nf);
        assert!(m1.abs() < 5.0 / nf.sqrt(), "mean {m1}");
        assert!((m2 - 1.0).abs() < 5.0 * (2.0 / nf).sqrt(), "variance {m2}");
        assert!(
            (m4 - 3.0).abs() < 5.0 * (96.0 / nf).sqrt(),
            "fourth moment {m4}"
        );
    }

    /// Pair keys are symmetric by construction and neighbouring keys are uncorrelated:
    /// the correlation of θ(step, i, j) with θ(step, i, j+1) and θ(step+1, i, j) is below 5/√n.
    #[test]
    fn neighbouring_keys_are_uncorrelated() {
        let key = StreamKey::new(99, Purpose::DpdPair, 0);
        let n = 200_000u32;
        let (mut c_id, mut c_step) = (0.0, 0.0);
        for i in 0..n {
            let g = key.gaussian(3, i, i + 1);
            c_id += g * key.gaussian(3, i, i + 2);
            c_step += g * key.gaussian(4, i, i + 1);
        }
        let nf = f64::from(n);
        assert!((c_id / nf).abs() < 5.0 / nf.sqrt());
        assert!((c_step / nf).abs() < 5.0 / nf.sqrt());
    }

    #[test]
    fn uniform_noise_has_unit_variance() {
        let key = StreamKey::new(5, Purpose::Test, 1);
        let n = 200_000u32;
        let (mut m1, mut m2) = (0.0, 0.0);
        for i in 0..n {
            let u = key.unit_variance_uniform(0, i, 0);
            assert!(u.abs() <= SQRT_3);
            m1 += u;
            m2 += u * u;
        }
        let nf = f64::from(n);
        assert!((m1 / nf).abs() < 5.0 / nf.sqrt());
        // Var(u²) for the uniform is 4/5 → standard error of the variance is √(0.8/n).
        assert!((m2 / nf - 1.0).abs() < 5.0 * (0.8 / nf).sqrt());
    }

    /// Moments of the pair-noise stream (ziggurat normals from the keyed hash): mean, variance,
    /// skewness and kurtosis within 5 standard errors, and the tail mass beyond 3 and 4 σ
    /// within 5 binomial standard errors of the normal values.
    #[test]
    fn hash_stream_normals_have_normal_moments_and_tails() {
        let n = 1_000_000u64;
        let (mut m1, mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0, 0.0);
        let (mut t3, mut t4) = (0u64, 0u64);
        for i in 0..n {
            let g = HashStream::new(42, Purpose::DpdPair, 17, i, i + 1).normal();
            m1 += g;
            m2 += g * g;
            m3 += g * g * g;
            m4 += g * g * g * g;
            t3 += u64::from(g.abs() > 3.0);
            t4 += u64::from(g.abs() > 4.0);
        }
        let nf = n as f64;
        let (m1, m2, m3, m4) = (m1 / nf, m2 / nf, m3 / nf, m4 / nf);
        assert!(m1.abs() < 5.0 / nf.sqrt(), "mean {m1}");
        assert!((m2 - 1.0).abs() < 5.0 * (2.0 / nf).sqrt(), "variance {m2}");
        assert!(m3.abs() < 5.0 * (15.0 / nf).sqrt(), "third moment {m3}");
        assert!(
            (m4 - 3.0).abs() < 5.0 * (96.0 / nf).sqrt(),
            "fourth moment {m4}"
        );
        for (count, p) in [(t3, 2.699_796_063e-3), (t4, 6.334_248_4e-5)] {
            let expected = p * nf;
            assert!(
                (count as f64 - expected).abs() < 5.0 * (expected * (1.0 - p)).sqrt(),
                "tail count {count} vs {expected}"
            );
        }
    }

    /// Neighbouring keys — the next pair id, the next step, the swapped ids, another seed —
    /// give uncorrelated numbers (|ρ| < 5/√n).
    #[test]
    fn hash_stream_neighbouring_keys_are_uncorrelated() {
        let n = 300_000u64;
        let mut c = [0.0f64; 4];
        for i in 0..n {
            let g = HashStream::new(7, Purpose::DpdPair, 100, i, i + 5).normal();
            let others = [
                HashStream::new(7, Purpose::DpdPair, 100, i, i + 6).normal(),
                HashStream::new(7, Purpose::DpdPair, 101, i, i + 5).normal(),
                HashStream::new(7, Purpose::DpdPair, 100, i + 5, i).normal(),
                HashStream::new(8, Purpose::DpdPair, 100, i, i + 5).normal(),
            ];
            for (acc, o) in c.iter_mut().zip(others) {
                *acc += g * o;
            }
        }
        for acc in c {
            let rho = acc / n as f64;
            assert!(rho.abs() < 5.0 / (n as f64).sqrt(), "correlation {rho}");
        }
    }

    /// The `static` ziggurat table is the one `ziggurat()` computes from R and V (to 4 ulp: the
    /// literals were printed from that computation; libm may differ in the last bit elsewhere).
    #[test]
    fn static_ziggurat_table_matches_its_formula() {
        let z = ziggurat();
        for i in 0..=ZIG_LAYERS {
            for (a, b) in [(ZIG_X[i], z.x[i]), (ZIG_F[i], z.f[i])] {
                assert!(
                    (a - b).abs() <= 4.0 * f64::EPSILON * b.abs(),
                    "entry {i}: {a} vs {b}"
                );
            }
        }
    }

    /// Standard normal tail mass P(|x| > t) = erfc(t/√2).
    fn normal_two_sided_tail(t: f64) -> f64 {
        // erfc by its continued fraction (Lentz), accurate to ~1e-15 for t/√2 ≥ 2.
        let z = t / std::f64::consts::SQRT_2;
        let mut f = z;
        let (mut c, mut d) = (z, 0.0);
        for k in 1..200 {
            let a = f64::from(k) / 2.0;
            d = 1.0 / (z + a * d);
            c = z + a / c;
            let delta = c * d;
            f *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (-z * z).exp() / (f * std::f64::consts::PI.sqrt())
    }

    #[test]
    fn normal_tail_formula_is_right() {
        // Tabulated P(|x| > 3) and P(|x| > 4).
        assert!((normal_two_sided_tail(3.0) / 2.699_796_063_260_2e-3 - 1.0).abs() < 1e-9);
        assert!((normal_two_sided_tail(4.0) / 6.334_248_366_623_98e-5 - 1.0).abs() < 1e-9);
    }

    /// Standard normal CDF Φ(t) = ½ erfc(−t/√2) (series for |t| < 3, tail beyond).
    fn normal_cdf(t: f64) -> f64 {
        if t.abs() >= 3.0 {
            let tail = 0.5 * normal_two_sided_tail(t.abs());
            return if t > 0.0 { 1.0 - tail } else { tail };
        }
        // Φ(t) = ½ + φ(t) Σ t^{2k+1} / (1·3·…·(2k+1)).
        let (mut term, mut sum) = (t, t);
        for k in 1..200 {
            term *= t * t / f64::from(2 * k + 1);
            sum += term;
            if term.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        0.5 + sum * (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt()
    }

    /// Moment and tail checks shared by the normal-generator tests; tolerance `K_SIGMA`
    /// standard errors (σ of the sample mean 1/√n, variance √(2/n), 3rd moment √(15/n), 4th
    /// √(96/n); binomial for tail counts).
    const K_SIGMA: f64 = 5.0;

    fn assert_normal_sample(xs: &[f64]) {
        let nf = xs.len() as f64;
        let (mut m1, mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0, 0.0);
        let (mut t3, mut t4, mut t_r) = (0u64, 0u64, 0u64);
        for &g in xs {
            m1 += g;
            m2 += g * g;
            m3 += g * g * g;
            m4 += g * g * g * g;
            t3 += u64::from(g.abs() > 3.0);
            t4 += u64::from(g.abs() > 4.0);
            t_r += u64::from(g.abs() > ZIG_R);
        }
        let (m1, m2, m3, m4) = (m1 / nf, m2 / nf, m3 / nf, m4 / nf);
        let k = K_SIGMA;
        assert!(m1.abs() < k / nf.sqrt(), "mean {m1}");
        assert!((m2 - 1.0).abs() < k * (2.0 / nf).sqrt(), "variance {m2}");
        assert!(m3.abs() < k * (15.0 / nf).sqrt(), "third moment {m3}");
        assert!(
            (m4 - 3.0).abs() < k * (96.0 / nf).sqrt(),
            "fourth moment {m4}"
        );
        // |x| > 3 (wedges), > R (the base strip's tail path) and > 4 (deep tail).
        for (count, t) in [(t3, 3.0), (t_r, ZIG_R), (t4, 4.0)] {
            let p = normal_two_sided_tail(t);
            let expected = p * nf;
            assert!(
                (count as f64 - expected).abs() < k * (expected * (1.0 - p)).sqrt(),
                "P(|x| > {t}): count {count} vs {expected}"
            );
        }
        // χ² of a 64-bin histogram on [−4, 4] plus two tail bins (equal widths 1/8): every
        // layer's rectangle and wedge show up here. dof = 65; bound dof + K_SIGMA √(2 dof).
        let bins = 64usize;
        let mut hist = vec![0u64; bins + 2];
        for &g in xs {
            let b = if g < -4.0 {
                0
            } else if g >= 4.0 {
                bins + 1
            } else {
                1 + (((g + 4.0) * 8.0) as usize).min(bins - 1)
            };
            hist[b] += 1;
        }
        let mut chi2 = 0.0;
        for (b, &count) in hist.iter().enumerate() {
            // The two tail bins have the same mass Φ(−4) by symmetry.
            let p = if b == 0 || b == bins + 1 {
                normal_cdf(-4.0)
            } else {
                let lo = -4.0 + (b - 1) as f64 / 8.0;
                normal_cdf(lo + 0.125) - normal_cdf(lo)
            };
            let e = p * nf;
            chi2 += (count as f64 - e).powi(2) / e;
        }
        let dof = (bins + 1) as f64;
        assert!(
            chi2 < dof + k * (2.0 * dof).sqrt(),
            "χ² {chi2} for {dof} dof"
        );
    }

    /// Many short keyed streams, as the dumbbells use them (3 000 normals per particle and step).
    #[test]
    fn normal_stream_has_normal_moments_tails_and_histogram() {
        let mut xs = Vec::with_capacity(4_000_000);
        let mut buf = vec![0.0; 3000];
        for gid in 0..1334u64 {
            NormalStream::new(42, Purpose::DumbbellNoise, 9, gid, 0).fill_normals(&mut buf);
            xs.extend_from_slice(&buf);
        }
        assert_normal_sample(&xs);
    }

    /// The first number of many different keys (the start of a stream, right after seeding).
    #[test]
    fn normal_stream_first_draws_over_keys_are_normal() {
        let xs: Vec<f64> = (0..1_000_000u64)
            .map(|gid| NormalStream::new(3, Purpose::DumbbellNoise, 1000, gid, 0).normal())
            .collect();
        assert_normal_sample(&xs);
    }

    /// Lag-1 (and lag-2, lag-3: one dumbbell's D components) correlation within a stream, and
    /// correlation between the streams of neighbouring keys — particle id ± 1, step ± 1, another
    /// seed, another purpose — position by position: |ρ| < K_SIGMA/√n each.
    #[test]
    fn normal_stream_is_uncorrelated_within_and_between_neighbouring_keys() {
        let len = 300usize;
        let (particles, step) = (4000u64, 77u64);
        let stream = |seed, purpose, step, gid| {
            let mut v = vec![0.0; len];
            NormalStream::new(seed, purpose, step, gid, 0).fill_normals(&mut v);
            v
        };
        let mut lag = [0.0f64; 3];
        let mut lag_n = 0usize;
        let mut cross = [0.0f64; 6];
        let mut cross_n = 0usize;
        for gid in 1..=particles {
            let me = stream(11, Purpose::DumbbellNoise, step, gid);
            for (l, acc) in lag.iter_mut().enumerate() {
                *acc += me.iter().zip(&me[l + 1..]).map(|(a, b)| a * b).sum::<f64>();
            }
            lag_n += len - 1; // (lags 2, 3 have a few fewer pairs: negligible)
            let others = [
                stream(11, Purpose::DumbbellNoise, step, gid + 1),
                stream(11, Purpose::DumbbellNoise, step, gid - 1),
                stream(11, Purpose::DumbbellNoise, step + 1, gid),
                stream(11, Purpose::DumbbellNoise, step - 1, gid),
                stream(12, Purpose::DumbbellNoise, step, gid),
                stream(11, Purpose::DumbbellInit, step, gid),
            ];
            for (acc, o) in cross.iter_mut().zip(&others) {
                *acc += me.iter().zip(o).map(|(a, b)| a * b).sum::<f64>();
            }
            cross_n += len;
        }
        for (l, acc) in lag.iter().enumerate() {
            let rho = acc / lag_n as f64;
            assert!(
                rho.abs() < K_SIGMA / (lag_n as f64).sqrt(),
                "lag-{} correlation {rho}",
                l + 1
            );
        }
        let names = ["gid+1", "gid-1", "step+1", "step-1", "seed+1", "purpose"];
        for (acc, name) in cross.iter().zip(names) {
            let rho = acc / cross_n as f64;
            assert!(
                rho.abs() < K_SIGMA / (cross_n as f64).sqrt(),
                "{name}: correlation {rho}"
            );
        }
        // Position by position across particles (e.g. the first draw after seeding of
        // neighbouring ids): correlation of draw k of gid with draw k of gid + 1.
        for k in [0usize, 1, 2, 299] {
            let mut acc = 0.0;
            for gid in 0..particles * 25 {
                let a = NormalStream::new(11, Purpose::DumbbellNoise, step, gid, 0);
                let b = NormalStream::new(11, Purpose::DumbbellNoise, step, gid + 1, 0);
                let nth = |mut s: NormalStream| {
                    for _ in 0..k {
                        s.normal();
                    }
                    s.normal()
                };
                acc += nth(a) * nth(b);
            }
            let n = (particles * 25) as f64;
            assert!(
                (acc / n).abs() < K_SIGMA / n.sqrt(),
                "draw {k}: {}",
                acc / n
            );
        }
    }

    #[test]
    fn normal_stream_is_a_function_of_its_key() {
        let mut a = NormalStream::new(5, Purpose::DumbbellNoise, 3, 8, 0);
        let mut b = a.clone();
        let mut buf = vec![0.0; 1000];
        a.fill_normals(&mut buf);
        for (k, x) in buf.iter().enumerate() {
            assert_eq!(x.to_bits(), b.normal().to_bits(), "draw {k}");
        }
        let mut c = NormalStream::new(5, Purpose::DumbbellNoise, 3, 8, 0);
        let mut again = vec![0.0; 1000];
        c.fill_normals(&mut again);
        assert_eq!(buf, again);
        // u ∈ (−1, 1) is symmetric and never ±1 or 0.
        for bits in [0u64, u64::MAX, 1 << 63, (1 << 63) - 1] {
            let (_, u) = ziggurat_layer_and_u(bits);
            assert!(u.abs() < 1.0 && u != 0.0, "{bits:x}: {u}");
        }
        assert_eq!(ziggurat_layer_and_u(0).1, -ziggurat_layer_and_u(u64::MAX).1);
    }

    /// xoshiro256++ reference output (Vigna's C code, state {1, 2, 3, 4}).
    #[test]
    fn xoshiro256plusplus_matches_the_reference() {
        let mut s = NormalStream { s: [1, 2, 3, 4] };
        let want = [41943041u64, 58720359, 3588806011781223, 3591011842654386];
        for w in want {
            assert_eq!(s.next_u64(), w);
        }
    }

    #[test]
    fn ziggurat_table_is_consistent() {
        let z = ziggurat();
        // Every layer has area V: x_i (f(x_{i+1}) − f(x_i)) = V (checked for the inner layers).
        for i in 1..ZIG_LAYERS - 1 {
            let area = z.x[i] * (z.f[i + 1] - z.f[i]);
            assert!((area - ZIG_V).abs() < 1e-9, "layer {i}: {area}");
        }
        assert!(z.x[ZIG_LAYERS - 1] > 0.0 && z.x[ZIG_LAYERS - 1] < 0.3);
    }
}
