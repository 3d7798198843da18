//! The editor shell (binary only; the library never sees egui).
//!
//! The UI reads the [`document::Document`] and the playback state and queues [`Command`]s,
//! which are drained once per frame. Loading runs on a background thread and is polled each
//! frame, so the window never freezes; a failed load shows an error dialog and leaves the
//! open project untouched.

mod app;
pub mod crowd;
mod document;
mod export;
mod inspect;
mod log_entry;
mod safety;
mod segment;
mod settings;
#[cfg(test)]
mod tests;
pub mod viewport;
mod views;

use std::path::PathBuf;

pub use app::{AppOptions, EditorApp};
#[cfg(test)]
pub use document::Command;

/// Nice value of the editor's bake threads. Measured on this 2-core machine with one
/// competing CPU-bound process (`yes`), default character, every representation: at nice 10
/// the editor's bake took 1.64× the command line's (231.7 s against 141.6 s) — any positive
/// nice leaves the bake about one core while the other process keeps the other — and at nice
/// 0 1.09× (154.1 s), with the window's frames at 3.8 ms CPU median and 15.6 ms at the 99th
/// percentile. `SCHED_IDLE`, used before, starved the bake outright (a 78-second bake took
/// over 20 minutes). So the bake keeps its fair share; the window stays responsive because
/// it asks for little while a bake runs (four redraws a second, playback and the crowd
/// preview held) and because the bake threads are `SCHED_BATCH`: the scheduler never lets
/// them preempt the window's thread when it wakes up for input.
pub const BAKE_NICE: i32 = 0;

/// [`BAKE_NICE`], or `POLYPOSTOR_BAKE_NICE` (0 to 19) when set: for measuring the trade-off.
pub fn bake_nice() -> i32 {
    std::env::var("POLYPOSTOR_BAKE_NICE")
        .ok()
        .and_then(|v| v.trim().parse::<i32>().ok())
        .filter(|n| (0..=19).contains(n))
        .unwrap_or(BAKE_NICE)
}

/// Marks the calling thread as batch work (Linux `SCHED_BATCH`) at [`bake_nice`]; threads it
/// starts inherit it. No-op elsewhere.
pub fn lower_thread_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: plain syscalls on the calling thread; a failure only leaves the priority as is.
    unsafe {
        let tid = libc::syscall(libc::SYS_gettid) as libc::pid_t;
        let param = libc::sched_param { sched_priority: 0 };
        libc::sched_setscheduler(tid, libc::SCHED_BATCH, &param);
        libc::setpriority(libc::PRIO_PROCESS, tid as libc::id_t, bake_nice());
    }
}

/// Records whether the window is drawn by a software rasteriser (see [`modal`]).
pub(crate) fn set_software_rendering(ctx: &egui::Context, software: bool) {
    ctx.data_mut(|d| d.insert_temp(software_id(), software));
}

fn software_id() -> egui::Id {
    egui::Id::unique("polypostor software rendering")
}

/// A modal dialog. On a software rasteriser its backdrop is left out: blending a translucent
/// quad over the whole window costs llvmpipe tens of milliseconds a frame (the dialog still
/// blocks the rest of the window).
pub(crate) fn modal(ctx: &egui::Context, id: &'static str) -> egui::Modal {
    let modal = egui::Modal::new(egui::Id::unique(id));
    if ctx.data(|d| d.get_temp::<bool>(software_id())).unwrap_or(false) {
        modal.backdrop_color(egui::Color32::TRANSPARENT)
    } else {
        modal
    }
}

/// Opens the editor window on `path` (a project folder, a project.json, or a .glb/.gltf).
pub fn run(path: PathBuf) -> anyhow::Result<()> {
    use eframe::egui_wgpu;
    use egui_wgpu::wgpu;
    // Bakes run on rayon's global pool: its threads yield to the window (see
    // `lower_thread_priority`). Fails only when a pool exists already, which then stays.
    let _ = rayon::ThreadPoolBuilder::new()
        .start_handler(|_| lower_thread_priority())
        .build_global();
    let mut wgpu_setup = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    let pref = polypostor::gpu::AdapterPreference::from_env();
    wgpu_setup.native_adapter_selector = Some(std::sync::Arc::new(
        move |adapters: &[wgpu::Adapter], surface: Option<&wgpu::Surface<'_>>| {
            let mut list: Vec<&wgpu::Adapter> = adapters
                .iter()
                .filter(|a| surface.is_none_or(|s| a.is_surface_supported(s)))
                .filter(|a| match &pref {
                    polypostor::gpu::AdapterPreference::Named(n) => {
                        a.get_info().name.to_lowercase().contains(&n.to_lowercase())
                    }
                    _ => true,
                })
                .collect();
            list.sort_by_key(|a| polypostor::gpu::rank_adapter(&a.get_info(), &pref));
            list.first()
                .map(|a| (*a).clone())
                .ok_or_else(|| "no GPU adapter can draw to this window".to_owned())
        },
    ));
    // egui asks an OpenGL adapter for WebGL 2 limits, which allow no storage buffers in vertex
    // shaders: the crowd preview's instanced renderers need them. Ask such an adapter for what
    // it has instead (desktop OpenGL, llvmpipe included, has them).
    let egui_device = wgpu_setup.device_descriptor.clone();
    wgpu_setup.device_descriptor = std::sync::Arc::new(move |adapter: &wgpu::Adapter| {
        let mut desc = egui_device(adapter);
        // Packs' BC7 atlases upload compressed where a hardware adapter samples them.
        desc.required_features |=
            adapter.features() & polypostor::gpu::optional_features(adapter.get_info().device_type);
        if adapter.get_info().backend == wgpu::Backend::Gl {
            let have = adapter.limits();
            desc.required_limits = wgpu::Limits {
                max_texture_dimension_2d: desc
                    .required_limits
                    .max_texture_dimension_2d
                    .min(have.max_texture_dimension_2d),
                ..have
            };
        }
        desc
    });
    let options = eframe::NativeOptions {
        renderer: eframe::Renderer::Wgpu,
        viewport: egui::ViewportBuilder::default()
            .with_title("Polypostor Studio")
            .with_inner_size([1440.0, 900.0])
            .with_min_inner_size([800.0, 500.0])
            .with_drag_and_drop(true),
        // egui's dithering is per-pixel noise in its fragment shader; flat UI colours do not
        // band, and on a software rasteriser it is a measurable share of every frame.
        dithering: false,
        wgpu_options: egui_wgpu::WgpuConfiguration {
            wgpu_setup: egui_wgpu::WgpuSetup::CreateNew(wgpu_setup),
            ..Default::default()
        },
        ..Default::default()
    };
    let app_options = AppOptions {
        settings_path: settings::default_path(),
        sync_loading: false,
        recovery_dir: settings::default_path().and_then(|p| p.parent().map(|d| d.join("recovery"))),
        autosave: true,
    };
    eframe::run_native(
        "Polypostor Studio",
        options,
        Box::new(move |cc| Ok(Box::new(EditorApp::new(cc, app_options, Some(path))))),
    )
    .map_err(|e| anyhow::anyhow!("cannot open the editor window: {e}"))
}
