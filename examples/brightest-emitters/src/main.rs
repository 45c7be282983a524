//! `fipt-brightest`: the `fipt` tool with the `brightest` emitter extractor registered (every
//! subcommand, preset and layout as in `fipt`).
fn main() {
    let components = brightest_emitters::register(fipt_cli::components());
    std::process::exit(fipt_cli::main_with(components));
}
