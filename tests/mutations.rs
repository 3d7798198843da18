//! Generated damage: packs, representation folders, project files and glTF/GLB files,
//! damaged in many ways by a seeded generator (truncated, bits flipped, bytes overwritten or
//! appended, absurd numbers, wrong types and missing keys in the JSON, files replaced by links
//! to devices, FIFOs, folders or nothing), each loaded by the library. Every case must end
//! in a typed error or a correct load: never a panic, never a hang (each case has
//! [`CASE_TIMEOUT`]), never an allocation beyond [`CASE_BUDGET`] (a counting allocator
//! measures each case's peak).
//!
//! `cargo test` runs [`DEFAULT_CASES`] cases per kind of input (a minute or two). A longer
//! run, with another seed:
//!
//! ```sh
//! POLYPOSTOR_MUTATIONS=20000 POLYPOSTOR_MUTATION_SEED=7 cargo test --release --test mutations
//! ```

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

/// Peak memory a single case may allocate above what was allocated when it started.
const CASE_BUDGET: usize = 256 << 20;
/// Longest a single case may take.
const CASE_TIMEOUT: Duration = Duration::from_secs(30);
/// Cases per kind of input in a plain `cargo test`.
const DEFAULT_CASES: usize = 500;

struct Counting;

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is forwarded to the system allocator; the counters only observe.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = CURRENT.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size > layout.size() {
                let now = CURRENT.fetch_add(new_size - layout.size(), Ordering::Relaxed) + new_size - layout.size();
                PEAK.fetch_max(now, Ordering::Relaxed);
            } else {
                CURRENT.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
            }
        }
        p
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// The suites run one at a time, so each case's peak is its own.
static SERIAL: Mutex<()> = Mutex::new(());

/// xorshift64*: small, seeded, reproducible.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn chance(&mut self, percent: u64) -> bool {
        self.next() % 100 < percent
    }
}

fn cases() -> usize {
    std::env::var("POLYPOSTOR_MUTATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES)
}

fn seed(kind: u64) -> u64 {
    let base: u64 = std::env::var("POLYPOSTOR_MUTATION_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x5eed);
    (base ^ (kind << 32)).max(1) | 1
}

/// Runs `load` on its own thread: it must return (typed error or success) within the timeout,
/// without panicking, allocating at most [`CASE_BUDGET`] more than before it started.
fn check_case(what: &str, load: impl FnOnce() -> Result<(), String> + Send + 'static) -> Result<(), String> {
    let base = CURRENT.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(load));
        let _ = tx.send(r);
    });
    let r = match rx.recv_timeout(CASE_TIMEOUT) {
        Ok(r) => r,
        Err(_) => panic!("{what}: no answer within {CASE_TIMEOUT:?} (a hang)"),
    };
    let peak = PEAK.load(Ordering::Relaxed).saturating_sub(base);
    assert!(
        peak <= CASE_BUDGET,
        "{what}: allocated {} MiB at its peak, more than the budget of {} MiB",
        peak >> 20,
        CASE_BUDGET >> 20
    );
    match r {
        Ok(result) => result,
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            panic!("{what}: panicked: {msg}")
        }
    }
}

// --- Damage -------------------------------------------------------------------------------

/// Damages bytes in place; returns what was done.
fn damage_bytes(rng: &mut Rng, bytes: &mut Vec<u8>) -> String {
    let n = bytes.len();
    match rng.below(7) {
        0 => {
            let to = rng.below(n + 1);
            bytes.truncate(to);
            format!("truncated to {to}")
        }
        1 => {
            let flips = 1 + rng.below(8);
            for _ in 0..flips {
                if n > 0 {
                    let k = rng.below(n);
                    bytes[k] ^= 1 << rng.below(8);
                }
            }
            format!("{flips} bits flipped")
        }
        2 => {
            let at = rng.below(n + 1);
            let len = (1 + rng.below(64)).min(n - at.min(n));
            for b in &mut bytes[at..at + len] {
                *b = rng.next() as u8;
            }
            format!("{len} bytes overwritten at {at}")
        }
        3 => {
            let extra = 1 + rng.below(4096);
            bytes.extend((0..extra).map(|_| rng.next() as u8));
            format!("{extra} bytes appended")
        }
        4 => {
            let at = rng.below(n + 1);
            let len = rng.below(256).min(n - at.min(n));
            let chunk = bytes[at..at + len].to_vec();
            let to = rng.below(bytes.len() + 1);
            bytes.splice(to..to, chunk);
            format!("{len} bytes from {at} repeated at {to}")
        }
        5 => {
            // An absurd little-endian number somewhere (a count, an offset, a float).
            let values: [u64; 6] = [0, u32::MAX as u64, u64::MAX, 0x7f80_0000, 0x7fc0_0000, 1 << 31];
            let v = values[rng.below(values.len())];
            let at = rng.below(n.saturating_sub(8) + 1);
            let width = [2usize, 4, 8][rng.below(3)].min(n - at.min(n));
            bytes[at..at + width].copy_from_slice(&v.to_le_bytes()[..width]);
            format!("{v:#x} written at {at}")
        }
        _ => {
            bytes.clear();
            "emptied".into()
        }
    }
}

/// Absurd JSON values of every type.
fn absurd(rng: &mut Rng) -> serde_json::Value {
    use serde_json::json;
    let pool = [
        json!(0),
        json!(-1),
        json!(u32::MAX),
        json!(u64::MAX),
        json!(1u64 << 53),
        json!(1e-45),
        json!(3.4e38),
        json!(1e39),
        json!(-1e308),
        json!(0.5),
        json!("text"),
        json!(""),
        json!("../../etc/passwd"),
        json!("/dev/zero"),
        json!(null),
        json!(true),
        json!([]),
        json!([0, 0, 0]),
        json!([1e39, 0, 0]),
        json!({}),
        json!({"a": 1}),
    ];
    pool[rng.below(pool.len())].clone()
}

/// Every path to a value in `v` (object keys and array indices).
fn paths(v: &serde_json::Value, prefix: &mut Vec<serde_json::Value>, out: &mut Vec<Vec<serde_json::Value>>) {
    out.push(prefix.clone());
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                prefix.push(k.clone().into());
                paths(x, prefix, out);
                prefix.pop();
            }
        }
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate().take(8) {
                prefix.push(i.into());
                paths(x, prefix, out);
                prefix.pop();
            }
        }
        _ => {}
    }
}

fn at_path<'a>(v: &'a mut serde_json::Value, path: &[serde_json::Value]) -> Option<&'a mut serde_json::Value> {
    let mut at = v;
    for p in path {
        at = match p {
            serde_json::Value::String(k) => at.get_mut(k.as_str())?,
            serde_json::Value::Number(i) => at.get_mut(i.as_u64()? as usize)?,
            _ => return None,
        };
    }
    Some(at)
}

/// Damages a JSON document at a random place; returns what was done.
fn damage_json(rng: &mut Rng, v: &mut serde_json::Value) -> String {
    let mut all = Vec::new();
    paths(v, &mut Vec::new(), &mut all);
    let path = all[rng.below(all.len())].clone();
    let shown = path.iter().map(|p| p.to_string()).collect::<Vec<_>>().join(".");
    match rng.below(5) {
        0 if !path.is_empty() => {
            // Remove the key / element.
            let (last, parent) = path.split_last().unwrap();
            if let Some(p) = at_path(v, parent) {
                match (p, last) {
                    (serde_json::Value::Object(m), serde_json::Value::String(k)) => {
                        m.remove(k);
                    }
                    (serde_json::Value::Array(a), serde_json::Value::Number(i)) => {
                        let i = i.as_u64().unwrap_or(0) as usize;
                        if i < a.len() {
                            a.remove(i);
                        }
                    }
                    _ => {}
                }
            }
            format!("removed {shown}")
        }
        1 => {
            // A number scaled or negated.
            if let Some(x) = at_path(v, &path)
                && let Some(f) = x.as_f64()
            {
                let factors = [-1.0, 1e6, 1e30, 1e-30, 65536.0, 0.0];
                let g = f * factors[rng.below(factors.len())];
                *x = serde_json::Number::from_f64(g).map_or(serde_json::Value::Null, Into::into);
            }
            format!("scaled {shown}")
        }
        2 => {
            // An array grown by repeating its elements (duplicates, too many entries).
            if let Some(serde_json::Value::Array(a)) = at_path(v, &path)
                && !a.is_empty()
            {
                let first = a[0].clone();
                let n = 1 + rng.below(64);
                a.extend(std::iter::repeat_n(first, n));
            }
            format!("grew {shown}")
        }
        _ => {
            let new = absurd(rng);
            let s = new.to_string();
            if let Some(x) = at_path(v, &path) {
                *x = new;
            }
            format!("{shown} = {s}")
        }
    }
}

/// Replaces `file` with something that is not a regular file of data.
#[cfg(unix)]
fn special(rng: &mut Rng, file: &Path) -> String {
    let _ = std::fs::remove_file(file);
    let _ = std::fs::remove_dir_all(file);
    match rng.below(5) {
        0 => {
            std::os::unix::fs::symlink("/dev/zero", file).unwrap();
            "a link to /dev/zero".into()
        }
        1 => {
            std::os::unix::fs::symlink("/dev/urandom", file).unwrap();
            "a link to /dev/urandom".into()
        }
        2 => {
            let c = std::ffi::CString::new(file.to_str().unwrap()).unwrap();
            // SAFETY: mkfifo on a path inside the test's own folder.
            unsafe { libc::mkfifo(c.as_ptr(), 0o600) };
            "a FIFO".into()
        }
        3 => {
            std::fs::create_dir(file).unwrap();
            "a folder".into()
        }
        _ => {
            std::os::unix::fs::symlink("/nonexistent/nothing", file).unwrap();
            "a dangling link".into()
        }
    }
}

fn default_glb() -> PathBuf {
    common::repo_path(polypostor::default_character::DEFAULT_CHARACTER_PATH)
}

// --- Suites -------------------------------------------------------------------------------

#[test]
fn damaged_packs_and_representation_folders() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = common::temp_dir("mutations-packs");
    let good = dir.join("good.pack");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_polypostor"))
        .args([
            "bake",
            default_glb().to_str().unwrap(),
            "--views",
            "3",
            "--resolution",
            "32",
        ])
        .args(["--representation", "all", "--out", good.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let files: Vec<String> = std::fs::read_dir(&good)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "report.json")
        .collect();
    let mut rng = Rng(seed(1));
    let (mut loaded, mut refused) = (0, 0);
    let case_dir = dir.join("case");
    for case in 0..cases() {
        common::copy_folder(&good, &case_dir);
        let mut done = Vec::new();
        for _ in 0..1 + rng.below(3) {
            let name = &files[rng.below(files.len())];
            let path = case_dir.join(name);
            if !std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file()) {
                continue; // already replaced by something special
            }
            let what = if name.ends_with(".json") && rng.chance(70) {
                match std::fs::read_to_string(&path)
                    .ok()
                    .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
                {
                    Some(mut v) => {
                        let w = damage_json(&mut rng, &mut v);
                        std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
                        w
                    }
                    None => "unreadable already".into(),
                }
            } else if cfg!(unix) && rng.chance(10) {
                #[cfg(unix)]
                {
                    special(&mut rng, &path)
                }
                #[cfg(not(unix))]
                String::new()
            } else {
                let mut bytes = std::fs::read(&path).unwrap_or_default();
                let w = damage_bytes(&mut rng, &mut bytes);
                let _ = std::fs::write(&path, &bytes);
                w
            };
            done.push(format!("{name}: {what}"));
        }
        // Half the time the damage is forged past the checksums.
        if rng.chance(50) {
            common::reseal(&case_dir.join("manifest.json"));
            common::reseal(&case_dir.join("representations.json"));
            done.push("resealed".into());
        }
        let what = format!("pack case {case} ({})", done.join("; "));
        let d = case_dir.clone();
        let full = rng.chance(25);
        let r = check_case(&what, move || {
            let pack = polypostor::pack::load_pack(&d).map(|_| ()).map_err(|e| e.to_string());
            let reps = polypostor::reps::load_representations(&d)
                .map(|_| ())
                .map_err(|e| e.to_string());
            if full {
                polypostor::scene::CrowdAssets::load(&d, Some(&default_glb()), None).map(|_| ())?;
            }
            pack.and(reps)
        });
        match r {
            Ok(()) => loaded += 1,
            Err(e) => {
                assert!(!e.trim().is_empty(), "{what}: an empty error");
                refused += 1;
            }
        }
    }
    eprintln!("packs: {loaded} loaded, {refused} refused with an error");
    assert!(
        refused > loaded,
        "most damage must be caught ({refused} refused, {loaded} loaded)"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn damaged_project_files() {
    use polypostor::bake::overrides::{OverrideBasis, Pin};
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = common::temp_dir("mutations-projects");
    let c = polypostor::default_character::generate();
    let seg = polypostor::bake::segment::auto_segment(&c);
    let mut p = polypostor::project::Project::new_for_character("p", &default_glb(), &dir);
    p.segmentation = Some(polypostor::project::StoredSegmentation::from_segmentation(&seg));
    let basis = OverrideBasis {
        views: 137,
        full_sphere: false,
        frames: 10,
    };
    let v = p.overrides.view_mut(basis, 3);
    v.key_frame = Some(2);
    v.order = Some(vec![4, 3, 2, 1, 0]);
    v.pins.insert(
        1,
        vec![Pin {
            frame: 2,
            source: 3,
            target: 4,
        }],
    );
    let good = serde_json::to_value(&p).unwrap();
    let file = dir.join("project.json");
    let mut rng = Rng(seed(2));
    let triangles = c.triangle_count();
    for case in 0..cases() {
        let what = if rng.chance(75) {
            let mut v = good.clone();
            let mut w = Vec::new();
            for _ in 0..1 + rng.below(3) {
                w.push(damage_json(&mut rng, &mut v));
            }
            std::fs::write(&file, serde_json::to_vec(&v).unwrap()).unwrap();
            w.join("; ")
        } else if cfg!(unix) && rng.chance(20) {
            #[cfg(unix)]
            {
                special(&mut rng, &file)
            }
            #[cfg(not(unix))]
            String::new()
        } else {
            let mut bytes = serde_json::to_vec(&good).unwrap();
            let w = damage_bytes(&mut rng, &mut bytes);
            let _ = std::fs::remove_dir_all(&file);
            let _ = std::fs::remove_file(&file);
            std::fs::write(&file, &bytes).unwrap();
            w
        };
        let what = format!("project case {case} ({what})");
        let f = file.clone();
        let _ = check_case(&what, move || {
            let (project, _) = polypostor::project::Project::load(&f).map_err(|e| e.to_string())?;
            // What the bake and the editor do with a loaded project.
            if let Some(s) = &project.segmentation {
                let _ = s.to_segmentation(triangles);
            }
            let d = project.overrides.audit(basis, 5);
            let _ = d.lines();
            for v in 0..basis.views + 2 {
                if let Some(o) = project.overrides.view(basis, v) {
                    for part in 0..6 {
                        let _ = o.pins_per_frame(part, basis.frames);
                    }
                }
            }
            Ok(())
        });
        let _ = std::fs::remove_dir_all(&file);
        let _ = std::fs::remove_file(&file);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn damaged_gltf_and_glb_files() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = common::temp_dir("mutations-gltf");
    let glb = std::fs::read(default_glb()).unwrap();
    let (json, glb_bin) = polypostor::gltf_write::glb_parts(&glb).unwrap();
    // A .gltf with its buffer beside it, too.
    let files = polypostor::gltf_write::write_gltf(
        &polypostor::default_character::generate(),
        &polypostor::gltf_write::BufferStorage::External("c.bin".into()),
    )
    .unwrap();
    let gltf_json: serde_json::Value = serde_json::from_str(&files.json).unwrap();
    let bin = files.bin.unwrap();
    let mut rng = Rng(seed(3));
    let (mut loaded, mut refused) = (0, 0);
    for case in 0..cases() {
        let case_dir = dir.join("case");
        let _ = std::fs::remove_dir_all(&case_dir);
        std::fs::create_dir_all(&case_dir).unwrap();
        let (what, path) = match rng.below(4) {
            0 => {
                let mut bytes = glb.clone();
                let w = damage_bytes(&mut rng, &mut bytes);
                std::fs::write(case_dir.join("c.glb"), &bytes).unwrap();
                (format!("GLB bytes: {w}"), case_dir.join("c.glb"))
            }
            1 => {
                let mut v = json.clone();
                let mut w = Vec::new();
                for _ in 0..1 + rng.below(3) {
                    w.push(damage_json(&mut rng, &mut v));
                }
                let container = polypostor::gltf_write::glb_container(&v, &glb_bin).unwrap();
                std::fs::write(case_dir.join("c.glb"), container).unwrap();
                (format!("GLB JSON: {}", w.join("; ")), case_dir.join("c.glb"))
            }
            2 => {
                let mut v = gltf_json.clone();
                let w = damage_json(&mut rng, &mut v);
                std::fs::write(case_dir.join("c.gltf"), serde_json::to_vec(&v).unwrap()).unwrap();
                std::fs::write(case_dir.join("c.bin"), &bin).unwrap();
                (format!(".gltf JSON: {w}"), case_dir.join("c.gltf"))
            }
            _ => {
                std::fs::write(case_dir.join("c.gltf"), &files.json).unwrap();
                let w = if cfg!(unix) && rng.chance(30) {
                    #[cfg(unix)]
                    {
                        special(&mut rng, &case_dir.join("c.bin"))
                    }
                    #[cfg(not(unix))]
                    String::new()
                } else {
                    let mut b = bin.clone();
                    let w = damage_bytes(&mut rng, &mut b);
                    std::fs::write(case_dir.join("c.bin"), &b).unwrap();
                    w
                };
                (format!(".bin: {w}"), case_dir.join("c.gltf"))
            }
        };
        let what = format!("glTF case {case} ({what})");
        let r = check_case(&what, move || {
            let c = polypostor::import_path(&path).map_err(|e| e.to_string())?;
            // What the editor and the bake do first with a character.
            let _ = polypostor::summary::Summary::of(&c);
            let _ = polypostor::bake::segment::auto_segment(&c);
            Ok(())
        });
        match r {
            Ok(()) => loaded += 1,
            Err(e) => {
                assert!(!e.trim().is_empty(), "{what}: an empty error");
                refused += 1;
            }
        }
    }
    eprintln!("glTF: {loaded} loaded, {refused} refused with an error");
    assert!(refused > 0 && loaded > 0, "{refused} refused, {loaded} loaded");
    std::fs::remove_dir_all(&dir).unwrap();
}
