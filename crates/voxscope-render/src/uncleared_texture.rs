//! A texture made without wgpu's zero fill, for the streaming atlas.
//!
//! wgpu zeroes a texture at its first use. For a 3D texture it does so with buffer copies from
//! a zeroed buffer, slice by slice; the first frame of every streaming renderer waited 11–25 ms
//! for the H200 beyond its own pass under 512 MiB, 51 ms under 2 GiB (runs 98 and 129), which
//! fits that fill (inferred: `--atlas-zero wgpu` against `shader` is to show it). A texture
//! wgpu wraps from its Vulkan backend (`create_texture_from_hal`) counts as initialized, so the
//! atlas is made that way where the device is a Vulkan GPU, and the renderer writes zeros into
//! every texel with a compute pass before anything reads one (`atlas_scatter.wgsl`'s `zero`,
//! through [`crate::staging_ring::StagingRing::zero_atlas`], in the volume's first write).
//! A CPU's Vulkan (lavapipe) stores from a shader more slowly than it copies, so there wgpu
//! fills the atlas (`StreamVolume::new` chooses).

/// The GPU has no room for the texture.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct OutOfMemory;

/// Makes a texture of `desc` through wgpu's Vulkan backend, which wgpu will not zero: its
/// texels are undefined until written. `None` where the device is not Vulkan, or `desc` is not
/// a plain texture this path makes (one mip level and sample; copy, sampling and storage uses
/// only; within the device's limits), or the backend failed otherwise: make it with
/// [`wgpu::Device::create_texture`] then. `Some(Err)` where the GPU has no room.
///
/// # Safety
///
/// No texel is read (sampled, loaded or copied from) before the caller has written it, and
/// `desc`'s format supports its usages on this device (wgpu does not check either for a
/// texture it wraps).
#[cfg(any(target_os = "linux", target_os = "windows", target_os = "android"))]
pub(crate) unsafe fn uncleared_texture(
    device: &wgpu::Device,
    desc: &wgpu::TextureDescriptor<'_>,
) -> Option<Result<wgpu::Texture, OutOfMemory>> {
    use wgpu::hal::Device as _;
    use wgpu::hal::api::Vulkan;
    let plain = wgpu::TextureUsages::COPY_SRC
        | wgpu::TextureUsages::COPY_DST
        | wgpu::TextureUsages::TEXTURE_BINDING
        | wgpu::TextureUsages::STORAGE_BINDING;
    let limits = device.limits();
    let side = match desc.dimension {
        wgpu::TextureDimension::D1 => limits.max_texture_dimension_1d,
        wgpu::TextureDimension::D2 => limits.max_texture_dimension_2d,
        wgpu::TextureDimension::D3 => limits.max_texture_dimension_3d,
    };
    let size = desc.size;
    if !plain.contains(desc.usage)
        || desc.mip_level_count != 1
        || desc.sample_count != 1
        || !desc.view_formats.is_empty()
        || size.width.max(size.height).max(size.depth_or_array_layers) > side
    {
        return None;
    }
    let hal_desc = wgpu::hal::TextureDescriptor {
        label: desc.label,
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: desc.dimension,
        format: desc.format,
        usage: hal_uses(desc.usage),
        memory_flags: wgpu::hal::MemoryFlags::empty(),
        view_formats: Vec::new(),
    };
    // SAFETY: the backend's device (`Sync`, shared with wgpu) only makes a texture of a
    // descriptor checked above against the device's limits, whose format the caller vouches
    // for.
    let made = {
        let hal_device = unsafe { device.as_hal::<Vulkan>() }?;
        unsafe { hal_device.create_texture(&hal_desc) }
    };
    let texture = match made {
        Ok(texture) => texture,
        Err(wgpu::hal::DeviceError::OutOfMemory) => return Some(Err(OutOfMemory)),
        // Lost or failed: wgpu's own path meets the same and reports it its way.
        Err(_) => return None,
    };
    // SAFETY: made by this device's backend from `desc`. Its texels are undefined: its first
    // use starts from UNINITIALIZED (which discards them) and the caller reads none before
    // writing it (this function's contract), so wgpu may count it as initialized.
    Some(Ok(unsafe {
        device.create_texture_from_hal::<Vulkan>(texture, desc, wgpu::TextureUses::UNINITIALIZED)
    }))
}

/// Elsewhere wgpu makes (and zeroes) every texture.
#[cfg(not(any(target_os = "linux", target_os = "windows", target_os = "android")))]
pub(crate) unsafe fn uncleared_texture(
    _device: &wgpu::Device,
    _desc: &wgpu::TextureDescriptor<'_>,
) -> Option<Result<wgpu::Texture, OutOfMemory>> {
    None
}

/// The backend's uses of a texture of `usage` (copies, sampling, storage: what
/// [`uncleared_texture`] makes). wgpu-core also sets the storage uses its format allows for
/// reading; Vulkan makes every storage use one usage bit, so these make the same image.
#[cfg(any(target_os = "linux", target_os = "windows", target_os = "android"))]
fn hal_uses(usage: wgpu::TextureUsages) -> wgpu::TextureUses {
    let mut uses = wgpu::TextureUses::empty();
    uses.set(
        wgpu::TextureUses::COPY_SRC,
        usage.contains(wgpu::TextureUsages::COPY_SRC),
    );
    uses.set(
        wgpu::TextureUses::COPY_DST,
        usage.contains(wgpu::TextureUsages::COPY_DST),
    );
    uses.set(
        wgpu::TextureUses::RESOURCE,
        usage.contains(wgpu::TextureUsages::TEXTURE_BINDING),
    );
    uses.set(
        wgpu::TextureUses::STORAGE_WRITE_ONLY,
        usage.contains(wgpu::TextureUsages::STORAGE_BINDING),
    );
    uses
}
