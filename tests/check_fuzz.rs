//! Fuzzes the case-file front end of `mesorheo check` for panics.
//!
//! Every stock case in `cases/` is mutated as text — a value replaced by an edge-case literal
//! (or by another of the key's documented choices), a number rescaled, a line deleted or
//! duplicated, a documented key inserted, a whole table appended from another stock case; 1–3
//! such mutations per variant — and each variant is taken through exactly what `mesorheo check`
//! does: parse and validate (`config::parse_scene`, with the error rendered as the CLI prints
//! it), then for 1 and 3 ranks the report (`check::report` or `check::flow_report`), the memory
//! check and the rank limit. Nothing is simulated.
//!
//! Rejections are expected; a panic (or a variant that does not finish within `HANG`) is a
//! defect. Every distinct panic location is reported with the smallest subset of its variant's
//! mutations that still triggers it. Deterministic: variant `i` of case `f` comes from a
//! SplitMix64 seeded by (f, i), so the long run's first variants are the normal run's.

use mesorheo::config::{self, CaseScene};
use std::cell::{Cell, RefCell};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::panic::PanicHookInfo;
use std::path::Path;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError, mpsc};
use std::time::{Duration, Instant};

/// Variants per stock case in the normal test.
const VARIANTS: usize = 2_000;
/// Variants per stock case in the long test unless `MESORHEO_FUZZ_VARIANTS` says otherwise.
const LONG_VARIANTS: usize = 20_000;
/// A variant still running after this long is reported as a hang.
const HANG: Duration = Duration::from_secs(10);
/// Hung workers abandoned (each keeps spinning until the test ends) before the fuzzing stops.
const MAX_HANGS: usize = 3;
/// Rank counts the check is run for.
const RANKS: [usize; 2] = [1, 3];

/// Replacement values: edge cases of every TOML type the case files use.
const LITERALS: &[&str] = &[
    "0",
    "-1",
    "1e300",
    "-1e-300",
    "nan",
    "inf",
    "-inf",
    "0.0",
    "1e-300",
    "\"\"",
    "[]",
    "[0.0]",
    "[1e9, 1e9, 1e9]",
    "true",
    "\"bogus\"",
    "2",
    "3",
    "1000000000",
    "4294967297",
    "18446744073709551615",
    "9223372036854775807",
    "-9223372036854775808",
    "[1e300, 1e300]",
];

/// Factors a number (or every number of an array) is rescaled by.
const SCALES: [f64; 3] = [1e-6, 1e6, -1.0];

#[test]
fn stock_cases_survive_mutations_through_check() {
    let report = fuzz(VARIANTS);
    assert!(report.is_clean(), "{report}");
    eprint!("{report}");
}

#[test]
#[ignore = "about 1.5 min in release at 20 000 variants per case (MESORHEO_FUZZ_VARIANTS)"]
fn long_fuzz_through_check() {
    let variants = std::env::var("MESORHEO_FUZZ_VARIANTS")
        .ok()
        .map(|v| {
            v.trim()
                .parse()
                .unwrap_or_else(|e| panic!("MESORHEO_FUZZ_VARIANTS={v}: {e}"))
        })
        .unwrap_or(LONG_VARIANTS);
    let report = fuzz(variants);
    assert!(report.is_clean(), "{report}");
    eprint!("{report}");
}

// ---------------------------------------------------------------------------------------------
// Randomness

/// SplitMix64 (Steele, Lea & Flood 2014): tiny, and good enough to pick mutations.
struct SplitMix64(u64);

impl SplitMix64 {
    /// The generator of variant `variant` of the case named `name`.
    fn for_variant(name: &str, variant: usize) -> Self {
        // FNV-1a of the name.
        let hash = name.bytes().fold(0xCBF2_9CE4_8422_2325_u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01B3)
        });
        let mut rng = Self(hash ^ (variant as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
        rng.next_u64();
        rng
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in 0..n (n > 0).
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

// ---------------------------------------------------------------------------------------------
// Stock cases and what mutations draw from

/// A `key = value` line of a stock case.
struct KeyLine {
    /// 0-based line number.
    line: usize,
    /// Dotted path as the key reference spells it (`fluid.polymer.b`, `reference[].value`).
    path: String,
    key: String,
    /// The value without its trailing comment.
    value: String,
}

/// A stock case file, split into lines.
struct Stock {
    name: String,
    lines: Vec<String>,
    keys: Vec<KeyLine>,
    /// Its tables: header line and the lines up to the next header.
    tables: Vec<Vec<String>>,
}

impl Stock {
    fn new(name: String, text: &str) -> Self {
        let lines: Vec<String> = text.lines().map(str::to_owned).collect();
        let mut keys = Vec::new();
        let mut tables: Vec<Vec<String>> = Vec::new();
        let mut table = String::new();
        for (line, raw) in lines.iter().enumerate() {
            let trimmed = raw.trim();
            if trimmed.starts_with('[') {
                table = table_path(trimmed);
                tables.push(vec![raw.clone()]);
                continue;
            }
            if let Some(current) = tables.last_mut() {
                current.push(raw.clone());
            }
            if trimmed.starts_with('#') {
                continue;
            }
            let Some((key, value)) = trimmed.split_once('=') else {
                continue;
            };
            let key = key.trim();
            let bare = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
            if key.is_empty() || !key.chars().all(bare) {
                continue;
            }
            keys.push(KeyLine {
                line,
                path: if table.is_empty() {
                    key.to_owned()
                } else {
                    format!("{table}.{key}")
                },
                key: key.to_owned(),
                value: strip_comment(value).trim().to_owned(),
            });
        }
        assert!(!keys.is_empty(), "cases/{name} has no `key = value` line");
        Self {
            name,
            lines,
            keys,
            tables,
        }
    }
}

/// `[fluid.polymer]` → `fluid.polymer`, `[[reference]]` → `reference[]`.
fn table_path(header: &str) -> String {
    match header.strip_prefix("[[").and_then(|h| h.strip_suffix("]]")) {
        Some(array) => format!("{}[]", array.trim()),
        None => header.trim_matches(['[', ']']).trim().to_owned(),
    }
}

/// The header line of a table path (inverse of `table_path`).
fn header_of(table: &str) -> String {
    match table.strip_suffix("[]") {
        Some(array) => format!("[[{array}]]"),
        None => format!("[{table}]"),
    }
}

/// A value without its trailing `# comment` (a `#` inside a string stays).
fn strip_comment(value: &str) -> &str {
    let mut in_string = false;
    let mut escaped = false;
    for (i, c) in value.char_indices() {
        match c {
            _ if escaped => escaped = false,
            '\\' if in_string => escaped = true,
            '"' => in_string = !in_string,
            '#' if !in_string => return &value[..i],
            _ => {}
        }
    }
    value
}

/// A documented key: where it goes and its documented string choices.
struct DocKey {
    /// Table path (`""` at the top level).
    table: String,
    key: String,
    choices: Vec<String>,
    array: bool,
}

/// What mutations draw from besides the case itself.
struct Pools {
    /// Every key of `config::reference::keys()`.
    documented: Vec<DocKey>,
    /// Index into `documented` by dotted path.
    by_path: HashMap<String, usize>,
    /// Every table of every stock case, with the case's name.
    tables: Vec<(String, Vec<String>)>,
}

impl Pools {
    fn new(stocks: &[Stock]) -> Self {
        let documented: Vec<DocKey> = config::reference::keys()
            .iter()
            .map(|doc| {
                let (table, key) = doc.path.rsplit_once('.').unwrap_or(("", doc.path));
                DocKey {
                    table: table.to_owned(),
                    key: key.to_owned(),
                    choices: doc
                        .kind
                        .split('"')
                        .skip(1)
                        .step_by(2)
                        .filter(|s| !s.is_empty())
                        .map(str::to_owned)
                        .collect(),
                    array: doc.kind.contains("array"),
                }
            })
            .collect();
        let by_path = documented
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let path = if d.table.is_empty() {
                    d.key.clone()
                } else {
                    format!("{}.{}", d.table, d.key)
                };
                (path, i)
            })
            .collect();
        let tables = stocks
            .iter()
            .flat_map(|s| s.tables.iter().map(|t| (s.name.clone(), t.clone())))
            .collect();
        Self {
            documented,
            by_path,
            tables,
        }
    }

    /// A replacement value for a key documented as `doc` (if it is): sometimes one of its
    /// documented choices, otherwise an edge-case literal.
    fn value(&self, doc: Option<&DocKey>, rng: &mut SplitMix64) -> String {
        match doc {
            Some(d) if !d.choices.is_empty() && rng.below(3) == 0 => {
                if d.array {
                    let picks: Vec<String> = (0..1 + rng.below(3))
                        .map(|_| format!("\"{}\"", rng.pick(&d.choices)))
                        .collect();
                    format!("[{}]", picks.join(", "))
                } else {
                    format!("\"{}\"", rng.pick(&d.choices))
                }
            }
            _ => (*rng.pick(LITERALS)).to_owned(),
        }
    }
}

fn load_stock_cases() -> Vec<Stock> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.expect("a directory entry of cases/").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    assert!(!paths.is_empty(), "no case in {}", dir.display());
    paths
        .iter()
        .map(|p| {
            let text =
                std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            let name = p.file_name().expect("a file name").to_string_lossy();
            Stock::new(name.into_owned(), &text)
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Mutations

/// One text edit; line numbers are the stock file's (0-based), so edits compose independently
/// and any subset of a variant's edits can be replayed.
#[derive(Clone, Debug)]
enum Mutation {
    Replace {
        line: usize,
        text: String,
    },
    Delete {
        line: usize,
    },
    Duplicate {
        line: usize,
    },
    /// `text` inserted right under `header` (at the top when empty; header appended if missing).
    Insert {
        header: String,
        text: String,
    },
    /// A table of another stock case appended at the end.
    AppendTable {
        from: String,
        lines: Vec<String>,
    },
}

impl Mutation {
    /// The edit, compactly (1-based line numbers).
    fn describe(&self, stock: &Stock) -> String {
        let old = |line: usize| stock.lines[line].trim();
        match self {
            Self::Replace { line, text } => format!("L{}: `{}` → `{text}`", line + 1, old(*line)),
            Self::Delete { line } => format!("L{} deleted: `{}`", line + 1, old(*line)),
            Self::Duplicate { line } => format!("L{} duplicated: `{}`", line + 1, old(*line)),
            Self::Insert { header, text } if header.is_empty() => {
                format!("inserted at the top: `{text}`")
            }
            Self::Insert { header, text } => format!("inserted under {header}: `{text}`"),
            Self::AppendTable { from, lines } => {
                let keys: Vec<&str> = lines
                    .iter()
                    .map(|l| l.trim())
                    .filter(|l| !l.is_empty() && !l.starts_with('#'))
                    .collect();
                format!("appended from {from}: `{}`", keys.join(" / "))
            }
        }
    }
}

/// 1–3 random mutations of `stock`.
fn mutate(stock: &Stock, pools: &Pools, rng: &mut SplitMix64) -> Vec<Mutation> {
    let count = 1 + rng.below(3);
    (0..count).map(|_| mutation(stock, pools, rng)).collect()
}

fn mutation(stock: &Stock, pools: &Pools, rng: &mut SplitMix64) -> Mutation {
    let k = rng.pick(&stock.keys);
    let doc = pools.by_path.get(&k.path).map(|&i| &pools.documented[i]);
    match rng.below(100) {
        0..55 => Mutation::Replace {
            line: k.line,
            text: format!("{} = {}", k.key, pools.value(doc, rng)),
        },
        55..70 => Mutation::Replace {
            line: k.line,
            text: format!(
                "{} = {}",
                k.key,
                scaled(&k.value, *rng.pick(&SCALES)).unwrap_or_else(|| pools.value(doc, rng))
            ),
        },
        70..78 => Mutation::Delete { line: k.line },
        78..81 => Mutation::Duplicate { line: k.line },
        81..93 => {
            // A documented key: set where the case has it, inserted where it has not.
            let d = rng.pick(&pools.documented);
            let text = format!("{} = {}", d.key, pools.value(Some(d), rng));
            let path = if d.table.is_empty() {
                d.key.clone()
            } else {
                format!("{}.{}", d.table, d.key)
            };
            match stock.keys.iter().find(|k| k.path == path) {
                Some(k) => Mutation::Replace { line: k.line, text },
                None => Mutation::Insert {
                    header: if d.table.is_empty() {
                        String::new()
                    } else {
                        header_of(&d.table)
                    },
                    text,
                },
            }
        }
        _ => {
            // A table the case lacks (or one more entry of an array of tables).
            let others: Vec<&(String, Vec<String>)> = pools
                .tables
                .iter()
                .filter(|(from, lines)| {
                    let header = lines[0].trim();
                    *from != stock.name
                        && (header.starts_with("[[")
                            || !stock.lines.iter().any(|l| l.trim() == header))
                })
                .collect();
            let (from, lines) = *rng.pick(&others);
            Mutation::AppendTable {
                from: from.clone(),
                lines: lines.clone(),
            }
        }
    }
}

/// `value` (a number or an array of numbers) times `factor`, as TOML; integers stay integers
/// (saturating). None for anything else.
fn scaled(value: &str, factor: f64) -> Option<String> {
    let one = |v: &str| -> Option<String> {
        let v = v.trim();
        if let Ok(i) = v.parse::<i64>() {
            return Some(if factor < 0.0 {
                i.saturating_neg()
            } else if factor > 1.0 {
                i.saturating_mul(factor as i64)
            } else {
                i / (1.0 / factor).round() as i64
            })
            .map(|i| i.to_string());
        }
        let x = v.parse::<f64>().ok()? * factor;
        Some(match x {
            _ if x.is_nan() => "nan".to_owned(),
            _ if x.is_infinite() => if x > 0.0 { "inf" } else { "-inf" }.to_owned(),
            _ => format!("{x:?}"),
        })
    };
    match value.strip_prefix('[').and_then(|v| v.strip_suffix(']')) {
        Some(items) if !items.trim().is_empty() => {
            let items: Option<Vec<String>> = items.split(',').map(one).collect();
            Some(format!("[{}]", items?.join(", ")))
        }
        Some(_) => None,
        None => one(value),
    }
}

/// The stock text with `mutations` applied in order.
fn apply(stock: &Stock, mutations: &[Mutation]) -> String {
    // Each line with the stock line it is (None for copies and insertions).
    let mut out: Vec<(Option<usize>, String)> = stock
        .lines
        .iter()
        .enumerate()
        .map(|(i, l)| (Some(i), l.clone()))
        .collect();
    let find = |out: &[(Option<usize>, String)], line: usize| {
        out.iter().position(|(origin, _)| *origin == Some(line))
    };
    for m in mutations {
        match m {
            Mutation::Replace { line, text } => {
                if let Some(p) = find(&out, *line) {
                    out[p].1.clone_from(text);
                }
            }
            Mutation::Delete { line } => {
                if let Some(p) = find(&out, *line) {
                    out.remove(p);
                }
            }
            Mutation::Duplicate { line } => {
                if let Some(p) = find(&out, *line) {
                    let copy = out[p].1.clone();
                    out.insert(p + 1, (None, copy));
                }
            }
            Mutation::Insert { header, text } => {
                let at = if header.is_empty() {
                    Some(0)
                } else {
                    out.iter()
                        .position(|(_, l)| l.trim() == header)
                        .map(|p| p + 1)
                };
                match at {
                    Some(p) => out.insert(p, (None, text.clone())),
                    None => out.extend([(None, header.clone()), (None, text.clone())]),
                }
            }
            Mutation::AppendTable { lines, .. } => {
                out.extend(lines.iter().map(|l| (None, l.clone())));
            }
        }
    }
    let mut text = String::new();
    for (_, line) in out {
        text.push_str(&line);
        text.push('\n');
    }
    text
}

// ---------------------------------------------------------------------------------------------
// The check, as `mesorheo check` runs it, with panics caught

/// What one variant did.
#[derive(Debug)]
enum Outcome {
    /// Parsed, validated and reported.
    Accepted,
    /// Refused with a case error (expected for most variants).
    Rejected,
    /// A defect.
    Panicked { location: String, message: String },
}

thread_local! {
    /// Whether panics on this thread are fuzzing outcomes (recorded, not printed).
    static FUZZING: Cell<bool> = const { Cell::new(false) };
    /// The last panic on this thread: location and message.
    static CAPTURED: RefCell<Option<(String, String)>> = const { RefCell::new(None) };
}

/// `mesorheo check` on `text` for each of `RANKS`: parse and validate, then the report, the
/// memory check and the rank limit (main.rs, `Command::Check`). Whether the case was accepted.
fn check_like_the_cli(text: &str) -> bool {
    let scene = match config::parse_scene(text, Path::new("fuzzed.toml")) {
        Ok(scene) => scene,
        Err(e) => {
            // The CLI prints it.
            std::hint::black_box(e.to_string());
            return false;
        }
    };
    for ranks in RANKS {
        match &scene {
            CaseScene::Particles(case) => {
                std::hint::black_box(mesorheo::check::report(case, ranks));
                let memory = mesorheo::capacity::check_rank_memory(
                    case,
                    ranks,
                    mesorheo::capacity::available_memory(),
                );
                std::hint::black_box(memory.err());
                std::hint::black_box(mesorheo::capacity::max_ranks(case));
            }
            CaseScene::HomogeneousFlow(flow) => {
                let (text, verdict) = mesorheo::check::flow_report(flow, ranks);
                std::hint::black_box((text, verdict.err()));
            }
        }
    }
    true
}

fn check_text(text: &str) -> Outcome {
    outcome_of(|| check_like_the_cli(text))
}

/// Runs `check` (true: accepted), catching a panic with the location `CAPTURED` holds for it
/// (on a thread with `FUZZING` set, under `QuietPanics`).
fn outcome_of(check: impl FnOnce() -> bool + std::panic::UnwindSafe) -> Outcome {
    CAPTURED.with(|c| c.borrow_mut().take());
    match std::panic::catch_unwind(check) {
        Ok(true) => Outcome::Accepted,
        Ok(false) => Outcome::Rejected,
        Err(payload) => {
            let (location, message) =
                CAPTURED.with(|c| c.borrow_mut().take()).unwrap_or_else(|| {
                    let message = payload
                        .downcast_ref::<&str>()
                        .map(|s| (*s).to_owned())
                        .or_else(|| payload.downcast_ref::<String>().cloned())
                        .unwrap_or_else(|| "<non-string payload>".to_owned());
                    ("<unknown location>".to_owned(), message)
                });
            Outcome::Panicked { location, message }
        }
    }
}

type Hook = Box<dyn Fn(&PanicHookInfo<'_>) + Sync + Send + 'static>;

/// While alive, panics on fuzzing threads are recorded in `CAPTURED` instead of printed;
/// others go to the previous hook, which is put back on drop. Also serialises the tests of this
/// file (the hook is process-wide).
struct QuietPanics {
    previous: Option<Arc<Hook>>,
    _serial: MutexGuard<'static, ()>,
}

impl QuietPanics {
    fn install() -> Self {
        static SERIAL: Mutex<()> = Mutex::new(());
        let serial = SERIAL.lock().unwrap_or_else(PoisonError::into_inner);
        let previous: Arc<Hook> = Arc::new(std::panic::take_hook());
        let forward = Arc::clone(&previous);
        std::panic::set_hook(Box::new(move |info| {
            if FUZZING.with(Cell::get) {
                let location = info.location().map_or_else(
                    || "<unknown location>".to_owned(),
                    |l| format!("{}:{}:{}", l.file(), l.line(), l.column()),
                );
                let message = info.payload_as_str().unwrap_or("<non-string payload>");
                CAPTURED.with(|c| *c.borrow_mut() = Some((location, message.to_owned())));
            } else {
                forward(info);
            }
        }));
        Self {
            previous: Some(previous),
            _serial: serial,
        }
    }
}

impl Drop for QuietPanics {
    fn drop(&mut self) {
        // The hook cannot be changed from a panicking thread; the process is failing anyway.
        if std::thread::panicking() {
            return;
        }
        drop(std::panic::take_hook());
        if let Some(previous) = self.previous.take() {
            match Arc::try_unwrap(previous) {
                Ok(hook) => std::panic::set_hook(hook),
                Err(shared) => std::panic::set_hook(Box::new(move |info| shared(info))),
            }
        }
    }
}

/// A thread checking variants, so that one that never finishes can be abandoned.
struct Worker {
    jobs: mpsc::Sender<String>,
    outcomes: mpsc::Receiver<Outcome>,
    /// Workers given up on so far (each still spinning on its variant).
    abandoned: usize,
}

impl Worker {
    fn spawn(abandoned: usize) -> Self {
        let (jobs, job_queue) = mpsc::channel::<String>();
        let (results, outcomes) = mpsc::channel();
        std::thread::Builder::new()
            .name("check-fuzz".into())
            .spawn(move || {
                FUZZING.with(|f| f.set(true));
                for text in job_queue {
                    if results.send(check_text(&text)).is_err() {
                        break;
                    }
                }
            })
            .expect("spawn a fuzzing thread");
        Self {
            jobs,
            outcomes,
            abandoned,
        }
    }

    /// The outcome of `text`, or None when it is not back within `HANG` (this worker is then
    /// replaced by a fresh one).
    fn check(&mut self, text: String) -> Option<Outcome> {
        let outcome = self
            .jobs
            .send(text)
            .ok()
            .and_then(|()| self.outcomes.recv_timeout(HANG).ok());
        if outcome.is_none() {
            *self = Self::spawn(self.abandoned + 1);
        }
        outcome
    }
}

// ---------------------------------------------------------------------------------------------
// The fuzzing loop and its report

/// A variant, reproducibly: the case, the variant index and its edits.
struct Example {
    case: String,
    variant: usize,
    edits: Vec<String>,
}

impl Example {
    fn new(stock: &Stock, variant: usize, mutations: &[Mutation]) -> Self {
        Self {
            case: stock.name.clone(),
            variant,
            edits: mutations.iter().map(|m| m.describe(stock)).collect(),
        }
    }
}

/// Every panic at one source location.
struct Finding {
    message: String,
    count: usize,
    cases: BTreeSet<String>,
    /// The first variant that hit it, cut down to the fewest edits that still do.
    example: Example,
}

#[derive(Default)]
struct Tally {
    accepted: usize,
    rejected: usize,
    panicked: usize,
    hung: usize,
}

struct Report {
    cases: usize,
    variants: usize,
    seconds: f64,
    tally: Tally,
    /// By panic location.
    findings: BTreeMap<String, Finding>,
    hangs: Vec<Example>,
    /// Stock cases that fail unmutated (not a panic; reported, not failed on).
    stock_rejected: Vec<String>,
    stopped_early: bool,
}

impl Report {
    fn is_clean(&self) -> bool {
        self.findings.is_empty() && self.hangs.is_empty()
    }
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let t = &self.tally;
        writeln!(
            f,
            "check fuzz: {} cases × {} variants in {:.1} s: {} accepted, {} rejected, {} \
             panicked, {} hung{}",
            self.cases,
            self.variants,
            self.seconds,
            t.accepted,
            t.rejected,
            t.panicked,
            t.hung,
            if self.stopped_early {
                " (stopped early: too many hangs)"
            } else {
                ""
            }
        )?;
        for name in &self.stock_rejected {
            writeln!(f, "note: stock case {name} is rejected unmutated")?;
        }
        if !self.findings.is_empty() {
            writeln!(f, "{} distinct panic location(s):", self.findings.len())?;
        }
        for (location, finding) in &self.findings {
            let e = &finding.example;
            let cases: Vec<&str> = finding.cases.iter().map(String::as_str).collect();
            writeln!(
                f,
                "- {location}: {}\n    {}× in {}\n    e.g. cases/{} variant {}: {}",
                finding.message,
                finding.count,
                cases.join(", "),
                e.case,
                e.variant,
                e.edits.join("; ")
            )?;
        }
        for e in &self.hangs {
            writeln!(
                f,
                "- hang (> {} s): cases/{} variant {}: {}",
                HANG.as_secs(),
                e.case,
                e.variant,
                e.edits.join("; ")
            )?;
        }
        Ok(())
    }
}

/// The smallest subset of `mutations` (fewest edits first) that still panics at `location`.
fn minimise(
    worker: &mut Worker,
    stock: &Stock,
    mutations: &[Mutation],
    location: &str,
) -> Vec<Mutation> {
    let n = mutations.len();
    let mut subsets: Vec<Vec<usize>> = (1..(1_u32 << n) - 1)
        .map(|mask| (0..n).filter(|i| mask & (1 << i) != 0).collect())
        .collect();
    subsets.sort_by_key(Vec::len);
    for subset in subsets {
        let chosen: Vec<Mutation> = subset.iter().map(|&i| mutations[i].clone()).collect();
        if let Some(Outcome::Panicked { location: l, .. }) = worker.check(apply(stock, &chosen))
            && l == location
        {
            return chosen;
        }
    }
    mutations.to_vec()
}

/// Runs `variants` mutations of every stock case through the check.
fn fuzz(variants: usize) -> Report {
    let start = Instant::now();
    let stocks = load_stock_cases();
    let pools = Pools::new(&stocks);
    let quiet = QuietPanics::install();
    let mut worker = Worker::spawn(0);
    let mut report = Report {
        cases: stocks.len(),
        variants,
        seconds: 0.0,
        tally: Tally::default(),
        findings: BTreeMap::new(),
        hangs: Vec::new(),
        stock_rejected: Vec::new(),
        stopped_early: false,
    };
    'cases: for stock in &stocks {
        if !matches!(worker.check(apply(stock, &[])), Some(Outcome::Accepted)) {
            report.stock_rejected.push(stock.name.clone());
        }
        let mut tally = Tally::default();
        for variant in 0..variants {
            if worker.abandoned >= MAX_HANGS {
                report.stopped_early = true;
                break 'cases;
            }
            let mut rng = SplitMix64::for_variant(&stock.name, variant);
            let mutations = mutate(stock, &pools, &mut rng);
            match worker.check(apply(stock, &mutations)) {
                Some(Outcome::Accepted) => tally.accepted += 1,
                Some(Outcome::Rejected) => tally.rejected += 1,
                Some(Outcome::Panicked { location, message }) => {
                    tally.panicked += 1;
                    if let Some(finding) = report.findings.get_mut(&location) {
                        finding.count += 1;
                        finding.cases.insert(stock.name.clone());
                    } else {
                        let minimal = minimise(&mut worker, stock, &mutations, &location);
                        let finding = Finding {
                            message: message.chars().take(400).collect(),
                            count: 1,
                            cases: BTreeSet::from([stock.name.clone()]),
                            example: Example::new(stock, variant, &minimal),
                        };
                        report.findings.insert(location, finding);
                    }
                }
                None => {
                    tally.hung += 1;
                    report.hangs.push(Example::new(stock, variant, &mutations));
                }
            }
        }
        eprintln!(
            "{:<40} {:>7} accepted {:>7} rejected {:>5} panicked {:>3} hung",
            stock.name, tally.accepted, tally.rejected, tally.panicked, tally.hung
        );
        report.tally.accepted += tally.accepted;
        report.tally.rejected += tally.rejected;
        report.tally.panicked += tally.panicked;
        report.tally.hung += tally.hung;
    }
    drop(quiet);
    report.seconds = start.elapsed().as_secs_f64();
    report
}

// ---------------------------------------------------------------------------------------------
// The harness itself

#[test]
fn mutations_edit_the_intended_lines() {
    let stock = Stock::new(
        "t.toml".into(),
        "# c\ndimension = 2\n[box]\nlengths = [1.0, 2.0] # L\n[[reference]]\nvalue = 3\n",
    );
    let paths: Vec<&str> = stock.keys.iter().map(|k| k.path.as_str()).collect();
    assert_eq!(paths, ["dimension", "box.lengths", "reference[].value"]);
    assert_eq!(stock.keys[1].value, "[1.0, 2.0]");
    let text = apply(
        &stock,
        &[
            Mutation::Replace {
                line: 3,
                text: "lengths = nan".into(),
            },
            Mutation::Duplicate { line: 1 },
            Mutation::Delete { line: 5 },
            Mutation::Insert {
                header: "[box]".into(),
                text: "shear_rate = 1.0".into(),
            },
            Mutation::Insert {
                header: "[walls]".into(),
                text: "axis = \"y\"".into(),
            },
        ],
    );
    assert_eq!(
        text,
        "# c\ndimension = 2\ndimension = 2\n[box]\nshear_rate = 1.0\nlengths = nan\n\
         [[reference]]\n[walls]\naxis = \"y\"\n"
    );
    assert_eq!(scaled("[1.0, 2.0]", -1.0).as_deref(), Some("[-1.0, -2.0]"));
    assert_eq!(scaled("12000", 1e6).as_deref(), Some("12000000000"));
    assert_eq!(scaled("12000", 1e-6).as_deref(), Some("0"));
    assert_eq!(scaled("1.5e-3", 1e6).as_deref(), Some("1500.0"));
    assert_eq!(scaled("\"sph\"", 1e6), None);
    assert_eq!(strip_comment("\"a # b\" # c"), "\"a # b\" ");
}

#[test]
fn panics_are_caught_with_their_location() {
    let quiet = QuietPanics::install();
    let outcome = std::thread::spawn(|| {
        FUZZING.with(|f| f.set(true));
        outcome_of(|| panic!("deliberate {}", 42))
    })
    .join()
    .expect("the panic is caught");
    drop(quiet);
    let Outcome::Panicked { location, message } = outcome else {
        panic!("expected a panic, got {outcome:?}");
    };
    assert!(location.starts_with("tests/check_fuzz.rs:"), "{location}");
    assert_eq!(message, "deliberate 42");
    assert!(matches!(outcome_of(|| false), Outcome::Rejected));
}
