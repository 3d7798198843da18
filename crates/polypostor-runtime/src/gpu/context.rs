//! Adapter selection and device creation.

/// Which adapters to prefer.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AdapterPreference {
    /// Hardware GPUs first, then software (Vulkan lavapipe, then GL llvmpipe).
    #[default]
    HardwareFirst,
    /// Software rasterisers first (reproducible images in tests).
    SoftwareFirst,
    /// The first adapter whose name contains this text (case-insensitive).
    Named(String),
}

impl AdapterPreference {
    /// From `POLYPOSTOR_ADAPTER` (`gpu`, `cpu` or part of a name), else the default.
    pub fn from_env() -> Self {
        match std::env::var("POLYPOSTOR_ADAPTER").ok().as_deref().map(str::trim) {
            None | Some("") | Some("gpu") | Some("hardware") => Self::HardwareFirst,
            Some("cpu") | Some("software") => Self::SoftwareFirst,
            Some(name) => Self::Named(name.to_string()),
        }
    }
}

/// Why no GPU context could be made, or an image could not be read back or drawn.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter on any backend (native, then OpenGL): no usable GPU driver is installed.
    #[error("no GPU adapter found (install Vulkan or OpenGL drivers, e.g. mesa-vulkan-drivers)")]
    NoAdapter,
    /// No adapter's name contains the text of [`AdapterPreference::Named`] (the text given).
    #[error("no adapter matches '{0}'")]
    NoMatchingAdapter(String),
    /// No candidate adapter could create a device; reports the last one tried.
    #[error("cannot create a device on '{adapter}': {message}")]
    Device {
        /// Name of the adapter that refused.
        adapter: String,
        /// wgpu's reason.
        message: String,
    },
    /// Copying a texture back to the CPU failed: waiting on the GPU, mapping the buffer, or an
    /// unexpected size; the message says which.
    #[error("GPU readback failed: {0}")]
    Readback(String),
    /// The assets cannot be drawn here: a representation that was not baked or could not be
    /// read, data past this GPU's limits, a bake that does not match the character or is
    /// inconsistent, or a crowd mix that cannot be made; the message says which.
    #[error("cannot draw this: {0}")]
    Unsupported(String),
}

/// Lower is better: hardware before software, then Vulkan, Metal, DX12, GL.
pub fn rank_adapter(info: &wgpu::AdapterInfo, pref: &AdapterPreference) -> (u32, u32) {
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    };
    let kind = if *pref == AdapterPreference::SoftwareFirst {
        4 - kind
    } else {
        kind
    };
    let backend = match info.backend {
        wgpu::Backend::Vulkan => 0,
        wgpu::Backend::Metal => 1,
        wgpu::Backend::Dx12 => 2,
        wgpu::Backend::Gl => 3,
        _ => 9,
    };
    (kind, backend)
}

/// Features a context asks for where the adapter has them: BC texture sampling (packs
/// store their atlases as BC7; without it they are decoded and uploaded as RGBA8).
pub const OPTIONAL_FEATURES: wgpu::Features = wgpu::Features::TEXTURE_COMPRESSION_BC;

/// The optional features worth asking an adapter of this type for: [`OPTIONAL_FEATURES`] on a
/// hardware GPU; none on a software rasteriser (llvmpipe, lavapipe, WARP), which samples BC7
/// by decoding the block in software at every texel fetch — the Polypostor crowd drew 14×
/// slower that way on llvmpipe than from the same atlases decoded once at load (0.92 against
/// 12.95 fps, 2,000 characters). Memory there is the machine's own, so blocks save nothing.
pub fn optional_features(device_type: wgpu::DeviceType) -> wgpu::Features {
    if device_type == wgpu::DeviceType::Cpu {
        wgpu::Features::empty()
    } else {
        OPTIONAL_FEATURES
    }
}

/// A device and queue on the chosen adapter.
pub struct GpuContext {
    /// The wgpu instance the adapter was enumerated from (native backends, or OpenGL alone when
    /// none of them had an adapter).
    pub instance: wgpu::Instance,
    /// The adapter in use (see [`GpuContext::adapter_description`]).
    pub adapter: wgpu::Adapter,
    /// The device, with wgpu's downlevel default limits raised to the adapter's texture sizes.
    pub device: wgpu::Device,
    /// The device's command queue.
    pub queue: wgpu::Queue,
}

impl GpuContext {
    /// A headless context on the preferred adapter.
    /// Asks for [`optional_features`] of the adapter chosen.
    pub fn new(pref: &AdapterPreference) -> Result<Self, GpuError> {
        Self::open(pref, |info| optional_features(info.device_type))
    }

    /// [`GpuContext::new`] asking for `optional` features where the adapter has them, on
    /// software rasterisers too (and only those: `wgpu::Features::empty()` makes a device that
    /// samples no BC7, as on an adapter without it).
    pub fn with_features(pref: &AdapterPreference, optional: wgpu::Features) -> Result<Self, GpuError> {
        Self::open(pref, |_| optional)
    }

    fn open(
        pref: &AdapterPreference,
        optional: impl Fn(&wgpu::AdapterInfo) -> wgpu::Features,
    ) -> Result<Self, GpuError> {
        // Native backends first; OpenGL only when none of them has an adapter (probing GL
        // needlessly costs time and prints driver noise).
        let native = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
        let mut found = None;
        for backends in [native, wgpu::Backends::GL] {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            desc.backends &= backends;
            if desc.backends.is_empty() {
                continue;
            }
            let instance = wgpu::Instance::new(desc);
            let adapters = pollster::block_on(instance.enumerate_adapters(backends));
            if !adapters.is_empty() {
                found = Some((instance, adapters));
                break;
            }
        }
        let Some((instance, mut adapters)) = found else {
            return Err(GpuError::NoAdapter);
        };
        if let AdapterPreference::Named(name) = pref {
            let needle = name.to_lowercase();
            adapters.retain(|a| a.get_info().name.to_lowercase().contains(&needle));
            if adapters.is_empty() {
                return Err(GpuError::NoMatchingAdapter(name.clone()));
            }
        }
        adapters.sort_by_key(|a| rank_adapter(&a.get_info(), pref));
        let mut last_err = None;
        for adapter in adapters {
            let info = adapter.get_info();
            let desc = wgpu::DeviceDescriptor {
                label: Some("polypostor"),
                required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
                required_features: adapter.features() & optional(&info),
                ..Default::default()
            };
            match pollster::block_on(adapter.request_device(&desc)) {
                Ok((device, queue)) => {
                    log::info!(
                        "GPU adapter: {} ({:?}, {:?})",
                        info.name,
                        info.backend,
                        info.device_type
                    );
                    return Ok(Self {
                        instance,
                        adapter,
                        device,
                        queue,
                    });
                }
                Err(e) => {
                    last_err = Some(GpuError::Device {
                        adapter: info.name.clone(),
                        message: e.to_string(),
                    })
                }
            }
        }
        Err(last_err.unwrap_or(GpuError::NoAdapter))
    }

    /// A context from `POLYPOSTOR_ADAPTER` or the default preference.
    pub fn from_env() -> Result<Self, GpuError> {
        Self::new(&AdapterPreference::from_env())
    }

    /// "name (backend, type)" of the adapter in use.
    pub fn adapter_description(&self) -> String {
        describe_adapter(&self.adapter.get_info())
    }
}

/// "name (backend, type)".
pub fn describe_adapter(info: &wgpu::AdapterInfo) -> String {
    format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn software_rasterisers_are_not_asked_to_sample_bc7() {
        assert_eq!(optional_features(wgpu::DeviceType::Cpu), wgpu::Features::empty());
        for t in [
            wgpu::DeviceType::DiscreteGpu,
            wgpu::DeviceType::IntegratedGpu,
            wgpu::DeviceType::VirtualGpu,
        ] {
            assert_eq!(optional_features(t), OPTIONAL_FEATURES);
        }
    }
}
