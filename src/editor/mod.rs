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

/// Opens the editor window on `path` (a project folder, a project.json, or a .glb/.gltf).
pub fn run(path: PathBuf) -> anyhow::Result<()> {
    use eframe::egui_wgpu;
    use egui_wgpu::wgpu;
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
    let options = eframe::NativeOptions {
        renderer: eframe::Renderer::Wgpu,
        viewport: egui::ViewportBuilder::default()
            .with_title("Polypostor Studio")
            .with_inner_size([1440.0, 900.0])
            .with_min_inner_size([800.0, 500.0])
            .with_drag_and_drop(true),
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
