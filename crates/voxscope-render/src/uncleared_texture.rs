//! A texture made without wgpu's zero fill, for the streaming atlas.
//!
//! wgpu zeroes a texture at its first use. For a 3D texture it does so with buffer copies from
//! a zeroed buffer, slice by slice, and a 512 MiB atlas took 24.7–24.9 ms of the GPU's time on
//! the H200 (run 129): the first frame of every streaming renderer waited for it. A texture
//! wgpu wraps from its Vulkan backend (`create_texture_from_hal`) counts as initialized, so the
//! atlas is made that way where the device is a Vulkan GPU, and its maker writes zeros into
//! every texel with a compute pass submitted before anything else uses it
//! (`atlas_scatter.wgsl`'s `zero`, through [`crate::staging_ring::StagingRing::zero_atlas`]).
//! A CPU's Vulkan (lavapipe) stores from a shader more slowly than it copies, so there wgpu
//! fills the atlas (`StreamVolume::new` chooses).

/// Makes a texture of `desc` through wgpu's Vulkan backend, which wgpu will not zero: its
/// texels are undefined until written. `None` where the device is not Vulkan (make it with
/// [`wgpu::Device::create_texture`] then); `Some(Err)` where the GPU has no room.
///
/// # Safety
///
/// The caller writes every texel before anything reads one, with the first command buffer
/// submitted that uses the texture.
#[cfg(any(target_os = "linux", target_os = "windows", target_os = "android"))]
pub(crate) unsafe fn uncleared_texture(
    device: &wgpu::Device,
    desc: &wgpu::TextureDescriptor<'_>,
) -> Option<Result<wgpu::Texture, String>> {
    use wgpu::hal::Device as _;
    use wgpu::hal::api::Vulkan;
    let hal_desc = wgpu::hal::TextureDescriptor {
        label: desc.label,
        size: desc.size,
        mip_level_count: desc.mip_level_count,
        sample_count: desc.sample_count,
        dimension: desc.dimension,
        format: desc.format,
        usage: hal_uses(desc.usage),
        memory_flags: wgpu::hal::MemoryFlags::empty(),
        view_formats: desc.view_formats.to_vec(),
    };
    // SAFETY: the backend's device only makes a texture of `desc` (which wgpu would accept:
    // the atlas's size is within the device's limits), and its guard is dropped before wgpu
    // uses the device again.
    let made = {
        let hal_device = unsafe { device.as_hal::<Vulkan>() }?;
        unsafe { hal_device.create_texture(&hal_desc) }
    };
    let texture = match made {
        Ok(texture) => texture,
        Err(error) => return Some(Err(error.to_string())),
    };
    // SAFETY: made by this device's backend from `desc`. Its contents are undefined, which its
    // first use (from UNINITIALIZED, which discards them) and this function's contract (the
    // caller writes every texel before any read) allow.
    Some(Ok(unsafe {
        device.create_texture_from_hal::<Vulkan>(texture, desc, wgpu::TextureUses::UNINITIALIZED)
    }))
}

/// Elsewhere wgpu makes (and zeroes) every texture.
#[cfg(not(any(target_os = "linux", target_os = "windows", target_os = "android")))]
pub(crate) unsafe fn uncleared_texture(
    _device: &wgpu::Device,
    _desc: &wgpu::TextureDescriptor<'_>,
) -> Option<Result<wgpu::Texture, String>> {
    None
}

/// The backend's uses of a texture of `usage`, as wgpu-core maps them for a format a shader
/// can write (the atlas's, where it is made this way).
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
