//! `fipt-oren-nayar`: the `fipt` tool with the `oren-nayar` reflectance model registered
//! (`fipt-oren-nayar run SCENE --config run.toml` with `[model] brdf = "oren-nayar"`, or
//! `fipt-oren-nayar synth cornell --brdf oren-nayar` to render views with it).
fn main() {
    let components = oren_nayar::register(fipt_cli::components());
    std::process::exit(fipt_cli::main_with(components));
}
