//! The measurements behind the command line's `compare` and `bench` commands: each
//! function checks its arguments before any work, writes its figures (JSON, plots,
//! pictures) and returns the table the command prints (or the JSON with `json`).
//!
//! - [`compare::compare`]: memory and error of every representation against the real mesh.
//! - [`bake::bench_bake`]: bake time per stage on every character, and the fast fit's gap.
//! - [`crowd::bench_crowd`], [`crowd::bench_stability`]: frames per second and GPU memory
//!   per representation and crowd size; the mix's temporal stability.
//! - [`sim::bench_sim`]: the crowd's CPU work per frame.

use std::path::Path;
use std::sync::atomic::AtomicBool;

pub mod bake;
pub mod compare;
pub mod crowd;
pub mod sim;

/// Appends one line to a command's text.
macro_rules! say {
    ($t:expr, $($a:tt)*) => {{
        use std::fmt::Write as _;
        let _ = writeln!($t, $($a)*);
    }};
}
/// Appends to a command's text without ending the line.
macro_rules! say_part {
    ($t:expr, $($a:tt)*) => {{
        use std::fmt::Write as _;
        let _ = write!($t, $($a)*);
    }};
}
pub(crate) use {say, say_part};

pub use crate::bake::report::human_bytes;

/// Checks, before any work, that the files a command will write into `dir` are new or its
/// own earlier output (and that `dir` is a folder, or can be made one).
pub fn check_output_files(dir: &Path, names: &[&str]) -> anyhow::Result<()> {
    if let Ok(m) = std::fs::symlink_metadata(dir)
        && !m.is_dir()
    {
        anyhow::bail!(
            "--out '{}' is {}, not a folder",
            dir.display(),
            crate::safe_fs::kind_of(&m.file_type())
        );
    }
    let kind = |n: &str| {
        if n.ends_with(".png") {
            crate::safe_fs::OutputFile::Png
        } else {
            crate::safe_fs::OutputFile::Json
        }
    };
    for n in names {
        crate::safe_fs::check_output_file(&dir.join(n), kind(n)).map_err(anyhow::Error::msg)?;
    }
    Ok(())
}

/// What a long measurement needs from its caller: where the repository is (its default
/// project, and `../shared` beside it), how to show a bake's progress, and the flag that
/// cancels the work.
pub struct Env<'a> {
    pub repo_root: &'a Path,
    pub progress: &'a (dyn Fn(crate::bake::pipeline::Progress) + Sync),
    pub cancel: &'a AtomicBool,
}

impl Env<'_> {
    /// Bakes `input` (a project or a glTF file) at its default settings with the
    /// representations `representation` (`all`, or a list) into `out`.
    pub fn bake(
        &self,
        ctx: &crate::gpu::GpuContext,
        input: &Path,
        out: &Path,
        representation: &str,
    ) -> anyhow::Result<()> {
        use crate::job::{BakeInput, Prepared, Request};
        let input = BakeInput::resolve(input, None).map_err(anyhow::Error::msg)?;
        let mut settings = input.settings();
        settings.representations = representation.to_owned();
        let prepared = Prepared::new(
            input,
            Request {
                settings,
                out: Some(out.to_owned()),
                ..Default::default()
            },
        )
        .map_err(anyhow::Error::msg)?;
        for w in &prepared.warnings {
            eprintln!("warning: {w}");
        }
        crate::job::run(ctx, &prepared.job(), self.progress, self.cancel, &|_, _| Ok(()))?;
        Ok(())
    }

    /// The default character baked with every representation into `out`.
    pub fn bake_default_all(&self, ctx: &crate::gpu::GpuContext, out: &Path) -> anyhow::Result<()> {
        eprintln!(
            "baking the default character with every representation into {} (pass --pack to reuse a bake)",
            out.display()
        );
        self.bake(
            ctx,
            &self.repo_root.join(crate::project::DEFAULT_PROJECT_DIR),
            out,
            "all",
        )
    }
}
