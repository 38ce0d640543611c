fn main() -> std::process::ExitCode {
    quiet_device_select();
    voxscope::cli::run()
}

/// Mesa's device-select Vulkan layer (loaded by every Vulkan application where Mesa is
/// installed) connects to the Wayland display to find the GPU that drives it, and where
/// `XDG_RUNTIME_DIR` is unset or no folder (a shell over ssh, a cron job, a container) it
/// cannot, and libwayland prints `error: XDG_RUNTIME_DIR is invalid or not set in the
/// environment.` twice on a render that succeeds: not voxscope's error, but it reads as one.
/// Without that folder there is no display for the layer to match, so it is switched off
/// (`NODEVICE_SELECT`, Mesa's own switch); a user's own setting stays, and so does the layer
/// where the user chose a GPU through it (`MESA_VK_DEVICE_SELECT`, `DRI_PRIME`).
fn quiet_device_select() {
    let runtime_dir = std::env::var_os("XDG_RUNTIME_DIR");
    let no_runtime_dir = runtime_dir.is_none_or(|dir| !std::path::Path::new(&dir).is_dir());
    let chosen = ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"]
        .iter()
        .any(|name| std::env::var_os(name).is_some());
    if no_runtime_dir && !chosen {
        // SAFETY: the first thing `main` does, before any thread exists that could read the
        // environment.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}
