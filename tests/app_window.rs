//! The real binary in a real X window (Xvfb): it opens a file given on the command line, draws
//! it, is photographed with ImageMagick's `import`, and quits cleanly on Ctrl+Q sent by xdotool.
//! Needs xvfb-run, xauth, xdotool and imagemagick (`.ci/run` installs them); fails without them.

use std::path::PathBuf;
use std::process::Command;

#[test]
fn the_binary_opens_a_file_draws_it_and_quits_cleanly_under_xvfb() {
    let binary = env!("CARGO_BIN_EXE_voxscope");
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/mri-head-128x128x62.nii.gz");
    let dir = tempfile::tempdir().expect("temp dir");
    let log = dir.path().join("voxscope.log");
    let shot = dir.path().join("screen.png");
    // A private config dir: the test neither reads nor overwrites the user's settings.
    let home = dir.path().join("home");
    let script = format!(
        r#"
        export HOME='{home}' XDG_CONFIG_HOME='{home}/.config' XDG_DATA_HOME='{home}/.local/share'
        '{binary}' '{file}' 2>'{log}' &
        pid=$!
        for i in $(seq 1 900); do
            grep -q '^voxscope: drew' '{log}' && break
            kill -0 $pid 2>/dev/null || break
            sleep 0.2
        done
        # The first present may lag the first draw on a loaded machine: photograph until the
        # middle of the screen is lit (ImageMagick's mean of a center crop), for up to 30 s.
        for i in $(seq 1 60); do
            sleep 0.5
            import -window root '{shot}'
            lit=$(convert '{shot}' -gravity center -crop 200x200+0+0 -format '%[fx:mean>0.05]' info:)
            [ "$lit" = 1 ] && break
        done
        window=$(xdotool search --sync --name '^voxscope$' | head -n 1)
        xdotool windowfocus --sync "$window" key --clearmodifiers ctrl+q
        for i in $(seq 1 150); do kill -0 $pid 2>/dev/null || break; sleep 0.2; done
        if kill -0 $pid 2>/dev/null; then kill -9 $pid; echo "exit=timeout"; else wait $pid; echo "exit=$?"; fi
        "#,
        home = home.display(),
        file = file.display(),
        log = log.display(),
        shot = shot.display(),
    );
    let output = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1600x1000x24", "bash", "-c", &script])
        .output()
        .expect("xvfb-run runs (install xvfb and xauth)");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let log_text = std::fs::read_to_string(&log).unwrap_or_default();
    let context = format!(
        "stdout:\n{stdout}\nstderr:\n{}\nvoxscope log:\n{log_text}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        log_text.contains("voxscope: drew"),
        "the app never drew\n{context}"
    );
    assert!(
        stdout.contains("exit=0"),
        "the app did not quit cleanly on Ctrl+Q\n{context}"
    );
    assert!(!log_text.contains("panicked"), "{context}");

    let screen = image::open(&shot)
        .expect("import wrote a screenshot")
        .to_rgba8();
    // Keep it where it can be looked at.
    let keep = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/test-images/app-xvfb.png");
    std::fs::create_dir_all(keep.parent().unwrap()).unwrap();
    screen.save(&keep).unwrap();
    let colors: std::collections::HashSet<[u8; 4]> = screen.pixels().map(|p| p.0).collect();
    assert!(
        colors.len() > 200,
        "the screen is nearly blank ({} colors)\n{context}",
        colors.len()
    );
    // The middle of the window is the volume: gray levels of a head, not one flat color.
    let (w, h) = screen.dimensions();
    let middle = image::imageops::crop_imm(&screen, w / 2 - 100, h / 2 - 100, 200, 200).to_image();
    let lit = middle.pixels().filter(|p| p.0[0] > 40).count();
    assert!(
        lit > 2000,
        "the center of the screen shows no volume ({lit} lit pixels)\n{context}"
    );
}
