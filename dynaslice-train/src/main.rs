fn main() -> std::process::ExitCode {
    dynaslice_train::cli::main()
}
