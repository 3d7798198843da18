//! PNG charts (`polypostor::plot`): the files are real 1000×600 PNGs, every series is
//! actually drawn in its palette colour, and odd input gives an `Err` (nothing drawable) or a
//! valid chart, never a panic.
//!
//! Decision tested here: input with nothing to draw (no labels, no series, no finite value,
//! or on a log axis no positive value) is an `Err` and writes no file; input with at least one
//! drawable value gives a valid chart in which the undrawable values are simply left out.
//!
//! Set `POLYPOSTOR_KEEP_PLOTS=1` to keep the written PNGs (their folder is printed).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use polypostor::plot::{HEIGHT, PALETTE, WIDTH, bar_chart, line_chart};

/// A fresh, unique folder under the system temp dir.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("polypostor-plot-test-{}-{name}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    fn path(&self, file: &str) -> PathBuf {
        self.0.join(file)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if std::env::var_os("POLYPOSTOR_KEEP_PLOTS").is_some() {
            eprintln!("plots kept in {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

fn load(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// Pixels within a small distance of `colour` (per channel).
fn count_near(img: &image::RgbImage, colour: (u8, u8, u8)) -> usize {
    let (r, g, b) = colour;
    img.pixels()
        .filter(|p| p[0].abs_diff(r) <= 12 && p[1].abs_diff(g) <= 12 && p[2].abs_diff(b) <= 12)
        .count()
}

/// Size, not a single colour, mostly white background.
fn check_basic(img: &image::RgbImage) {
    assert_eq!(img.dimensions(), (WIDTH, HEIGHT));
    assert_eq!((WIDTH, HEIGHT), (1000, 600));
    let first = *img.get_pixel(0, 0);
    assert!(img.pixels().any(|p| *p != first), "the image is a single colour");
    let white = count_near(img, (255, 255, 255));
    assert!(
        white > (WIDTH * HEIGHT / 3) as usize,
        "expected a white background, {white} white pixels"
    );
    // Dark pixels: text (title, legend, axis labels) and axes were drawn.
    let dark = img.pixels().filter(|p| p.0.iter().all(|&c| c < 80)).count();
    assert!(dark > 500, "expected text and axes, {dark} dark pixels");
}

/// Bar series: (name, one value per label).
type Bars = Vec<(String, Vec<f64>)>;
/// Line series: (name, points).
type Lines = Vec<(String, Vec<(f64, f64)>)>;

fn s(v: &str) -> String {
    v.to_string()
}

#[test]
fn bar_chart_draws_every_series() {
    let dir = TempDir::new("bars");
    let path = dir.path("memory.png");
    let labels = vec![s("LOD 0"), s("LOD 1"), s("LOD 2"), s("impostor")];
    let series = vec![
        (s("vertices"), vec![12.3, 8.1, 3.4, 0.9]),
        (s("indices"), vec![6.0, 4.2, 1.7, 0.5]),
        (s("textures"), vec![20.0, 20.0, 20.0, 31.5]),
    ];
    bar_chart(&path, "Memory per level (MB)", "MB", &labels, &series, false).unwrap();
    let img = load(&path);
    check_basic(&img);
    for (i, (name, _)) in series.iter().enumerate() {
        let n = count_near(&img, PALETTE[i]);
        assert!(n > 2000, "series {name}: {n} pixels of its colour");
    }
    // Colours of series that do not exist are absent.
    for (i, &colour) in PALETTE.iter().enumerate().skip(series.len()) {
        assert_eq!(count_near(&img, colour), 0, "palette colour {i}");
    }
}

#[test]
fn log_bar_chart_shows_small_values_next_to_large_ones() {
    let dir = TempDir::new("logbars");
    let path = dir.path("memory-log.png");
    let labels = vec![s("baseline"), s("polypostor"), s("billboards")];
    // 100 KB .. 100 MB, plus values a log axis cannot show.
    let series = vec![
        (s("GPU memory"), vec![100.0e6, 35.0e6, 0.0]),
        (s("atlas"), vec![f64::NAN, 150.0e3, 100.0e3]),
        (s("CPU memory"), vec![-1.0, 2.5e6, f64::INFINITY]),
    ];
    bar_chart(&path, "Memory (bytes, log scale)", "bytes", &labels, &series, true).unwrap();
    let img = load(&path);
    check_basic(&img);
    for (i, (name, _)) in series.iter().enumerate() {
        let n = count_near(&img, PALETTE[i]);
        // On a linear axis the 100 KB bars would be under one pixel tall next to 100 MB.
        assert!(n > 2000, "series {name}: {n} pixels of its colour");
    }

    // The same data on a linear axis: the small "atlas" bars all but vanish.
    let linear = dir.path("memory-linear.png");
    bar_chart(&linear, "Memory (bytes)", "bytes", &labels, &series, false).unwrap();
    let img = load(&linear);
    check_basic(&img);
    let atlas_linear = count_near(&img, PALETTE[1]);
    assert!(atlas_linear < 2000, "{atlas_linear} atlas pixels on a linear axis");
}

#[test]
fn line_chart_draws_every_series() {
    let dir = TempDir::new("lines");
    let path = dir.path("error.png");
    let wave = |phase: f64, scale: f64| -> Vec<(f64, f64)> {
        (0..48)
            .map(|f| (f as f64, scale * (1.5 + (f as f64 * 0.3 + phase).sin())))
            .collect()
    };
    let mut broken = wave(1.0, 0.5);
    broken[10].1 = f64::NAN;
    broken[20].0 = f64::INFINITY;
    broken[30] = (f64::NAN, f64::NEG_INFINITY);
    let series = vec![
        (s("LOD 1"), wave(0.0, 1.0)),
        (s("LOD 2"), broken),
        (s("impostor"), wave(2.0, 2.0)),
    ];
    line_chart(&path, "Error per frame", "frame", "error (px)", &series).unwrap();
    let img = load(&path);
    check_basic(&img);
    for (i, (name, _)) in series.iter().enumerate() {
        let n = count_near(&img, PALETTE[i]);
        assert!(n > 800, "series {name}: {n} pixels of its colour");
    }
}

#[test]
fn long_and_many_series_wrap_and_cycle_the_palette() {
    let dir = TempDir::new("many");
    let labels: Vec<String> = (0..6)
        .map(|i| format!("a rather long group label number {i}"))
        .collect();
    let series: Vec<(String, Vec<f64>)> = (0..8)
        .map(|k| {
            (
                format!("series with a long name {k}"),
                (0..6).map(|i| (1 + i + k) as f64 * 1.7).collect(),
            )
        })
        .collect();
    let path = dir.path("many-bars.png");
    bar_chart(&path, "Many series", "value", &labels, &series, false).unwrap();
    let img = load(&path);
    check_basic(&img);
    for (i, &colour) in PALETTE.iter().enumerate() {
        assert!(count_near(&img, colour) > 500, "palette colour {i}");
    }

    let lines: Vec<(String, Vec<(f64, f64)>)> = (0..8)
        .map(|k| {
            (
                format!("line {k}"),
                (0..1000).map(|f| (f as f64, (f * (k + 1)) as f64)).collect(),
            )
        })
        .collect();
    let path = dir.path("many-lines.png");
    line_chart(&path, "Long series", "frame", "value", &lines).unwrap();
    check_basic(&load(&path));

    // Far more series than the legend can list: it is cut to a few rows ("+N more") and the
    // chart keeps its room.
    let crowd: Lines = (0..40)
        .map(|k| (format!("variant {k}"), vec![(0.0, k as f64), (1.0, k as f64 + 1.0)]))
        .collect();
    let path = dir.path("crowd-lines.png");
    line_chart(&path, "Forty series", "x", "y", &crowd).unwrap();
    check_basic(&load(&path));
}

#[test]
fn nothing_to_draw_is_an_error_and_writes_no_file() {
    let dir = TempDir::new("empty");
    let path = dir.path("empty.png");
    let labels = vec![s("a"), s("b")];
    let nan = vec![(s("x"), vec![f64::NAN, f64::INFINITY])];
    let non_positive = vec![(s("x"), vec![0.0, -3.0])];
    let cases: Vec<(&str, Result<(), String>)> = vec![
        ("no labels", bar_chart(&path, "t", "y", &[], &[(s("x"), vec![])], false)),
        ("no series", bar_chart(&path, "t", "y", &labels, &[], false)),
        ("all NaN", bar_chart(&path, "t", "y", &labels, &nan, false)),
        (
            "log, nothing positive",
            bar_chart(&path, "t", "y", &labels, &non_positive, true),
        ),
        (
            "wrong length",
            bar_chart(&path, "t", "y", &labels, &[(s("x"), vec![1.0])], false),
        ),
        ("no lines", line_chart(&path, "t", "x", "y", &[])),
        ("empty lines", line_chart(&path, "t", "x", "y", &[(s("a"), vec![])])),
        (
            "NaN lines",
            line_chart(
                &path,
                "t",
                "x",
                "y",
                &[(s("a"), vec![(f64::NAN, 1.0), (2.0, f64::NAN)])],
            ),
        ),
    ];
    for (case, result) in cases {
        let err = result.expect_err(case);
        assert!(!err.is_empty(), "{case}: empty message");
        assert!(err.contains("\"t\""), "{case}: message names the chart: {err}");
    }
    assert!(!path.exists(), "no file is written for an error");
}

#[test]
fn odd_but_drawable_input_gives_a_valid_chart() {
    let dir = TempDir::new("odd");
    let labels = vec![s("a"), s("b"), s("c")];
    let cases: Vec<(&str, Bars, bool)> = vec![
        ("all zero", vec![(s("x"), vec![0.0, 0.0, 0.0])], false),
        ("negative", vec![(s("x"), vec![-1.0, -5.0, 2.0])], false),
        ("one value", vec![(s("x"), vec![f64::NAN, 7.0, f64::NAN])], true),
        ("power of ten", vec![(s("x"), vec![100.0, 100.0, 100.0])], true),
        ("huge", vec![(s("x"), vec![f64::MAX, 1.0, -f64::MAX])], false),
        ("tiny log", vec![(s("x"), vec![1e-300, 1e300, 5e-324])], true),
        (
            "empty series beside",
            vec![(s("x"), vec![1.0, 2.0, 3.0]), (s(""), vec![f64::NAN; 3])],
            false,
        ),
    ];
    for (i, (case, series, log)) in cases.iter().enumerate() {
        let path = dir.path(&format!("odd-bars-{i}.png"));
        match bar_chart(&path, case, "", &labels, series, *log) {
            Ok(()) => check_basic(&load(&path)),
            // Allowed only for values beyond what an axis can span.
            Err(e) => assert!(case.starts_with("huge") || case.starts_with("tiny"), "{case}: {e}"),
        }
    }

    let line_cases: Vec<(&str, Lines)> = vec![
        ("single point", vec![(s("p"), vec![(3.0, 4.0)])]),
        ("flat", vec![(s("p"), vec![(0.0, 2.0), (1.0, 2.0), (2.0, 2.0)])]),
        ("vertical", vec![(s("p"), vec![(1.0, 0.0), (1.0, 5.0)])]),
        (
            "one empty",
            vec![(s("p"), vec![]), (s("q"), vec![(0.0, 0.0), (1.0, 1.0)])],
        ),
        (
            "huge",
            vec![(s("p"), vec![(-f64::MAX, f64::MAX), (f64::MAX, -f64::MAX)])],
        ),
    ];
    for (i, (case, series)) in line_cases.iter().enumerate() {
        let path = dir.path(&format!("odd-lines-{i}.png"));
        match line_chart(&path, case, "x", "y", series) {
            Ok(()) => check_basic(&load(&path)),
            Err(e) => assert!(case.starts_with("huge"), "{case}: {e}"),
        }
    }
}

#[test]
fn the_file_is_png_whatever_its_extension_and_a_missing_folder_is_an_error() {
    let dir = TempDir::new("ext");
    let path = dir.path("chart.jpg");
    line_chart(&path, "t", "x", "y", &[(s("a"), vec![(0.0, 1.0), (1.0, 2.0)])]).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");

    let missing = dir.path("no/such/folder/chart.png");
    let err = line_chart(&missing, "t", "x", "y", &[(s("a"), vec![(0.0, 1.0)])]).unwrap_err();
    assert!(err.contains("chart.png"), "{err}");
}
