//! With the `oidn` feature: checks that OIDN_DIR holds the library (a clear message instead of a
//! linker error) and lets this crate's tests find it at run time (rpath).

fn main() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    if std::env::var_os("CARGO_FEATURE_OIDN").is_none() {
        return;
    }
    match oidn_lib_dir() {
        Ok(Some(lib)) => println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display()),
        Ok(None) => {} // pkg-config finds a system OIDN
        Err(message) => panic!("{message}"),
    }
}

/// `OIDN_DIR/lib` when OIDN_DIR is set (and holds the library), None when it is empty.
fn oidn_lib_dir() -> Result<Option<std::path::PathBuf>, String> {
    let Some(dir) = std::env::var_os("OIDN_DIR").filter(|d| !d.is_empty()) else {
        return Ok(None);
    };
    let lib = std::path::PathBuf::from(dir).join("lib");
    if lib.join("libOpenImageDenoise.so").exists() || lib.join("libOpenImageDenoise.dylib").exists()
    {
        Ok(Some(lib))
    } else {
        Err(format!(
            "the `denoise` feature needs Intel Open Image Denoise 2.x: {} has no libOpenImageDenoise. Run `bash crates/denoise/install-oidn.sh` (it installs the PyPI wheel pyoidn into .oidn/), or set OIDN_DIR to an OIDN install (OIDN_DIR= with an empty value: pkg-config)",
            lib.display()
        ))
    }
}
