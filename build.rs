//! Generates the gRPC code for proto/cleave.proto with the vendored protoc
//! (no system protoc is needed) and a file descriptor set for reflection.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut config = prost_build::Config::new();
    config.protoc_executable(protoc_bin_vendored::protoc_bin_path()?);
    let include = protoc_bin_vendored::include_path()?;
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR")?);
    tonic_prost_build::configure()
        .file_descriptor_set_path(out.join("cleave_descriptor.bin"))
        .compile_with_config(
            config,
            &[std::path::Path::new("proto/cleave.proto")],
            &[std::path::Path::new("proto"), include.as_path()],
        )?;
    println!("cargo:rerun-if-changed=proto/cleave.proto");
    Ok(())
}
