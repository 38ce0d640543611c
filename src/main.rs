fn main() -> std::process::ExitCode {
    voxscope::cli::run()
}
