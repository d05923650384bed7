fn main() -> std::process::ExitCode {
    realcam::cli::main()
}
