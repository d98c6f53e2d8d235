fn main() -> std::process::ExitCode {
    dynaslice_cli::main()
}
