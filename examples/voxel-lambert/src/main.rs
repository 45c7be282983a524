//! `fipt-voxel-lambert`: the `fipt` tool with the `voxel-lambert` method registered.
fn main() {
    let components = voxel_lambert::register(fipt_cli::components());
    std::process::exit(fipt_cli::main_with(components));
}
