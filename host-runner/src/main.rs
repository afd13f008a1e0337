fn main() {
    std::process::exit(tetradrill::cli::main());
}
