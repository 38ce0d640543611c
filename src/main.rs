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
/// (`NODEVICE_SELECT`, Mesa's own switch); a user's own setting stays.
fn quiet_device_select() {
    let runtime_dir = std::env::var_os("XDG_RUNTIME_DIR");
    let no_runtime_dir = runtime_dir.is_none_or(|dir| !std::path::Path::new(&dir).is_dir());
    if no_runtime_dir && std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: the first thing `main` does, before any thread exists that could read the
        // environment.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}
