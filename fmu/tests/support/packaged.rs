//! The packaged FMU under test, as `package-fmus` writes it, for the tests that
//! import FMUs through the `fmi` crate. The FMUs are packaged from the
//! `libkalfmu_fmu.so` that cargo builds for this very test run (under `cargo test`
//! the cdylib is only in `target/<profile>/deps/`). Set `KALFMU_FMU_DIR=path/to/dir`
//! (holding `<modelIdentifier>.fmu`, as `package-fmus --out` writes them) to test
//! released FMUs instead.

use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use kalfmu_fmu::catalogue;
use kalfmu_fmu::model_description::model_description;

/// The `.fmu` of `model` under test: in `KALFMU_FMU_DIR`, or packaged once per
/// test process (under a lock: the tests run in parallel) into `target/tmp/<dir>`,
/// a directory of the test binary's own (the other test binaries may write theirs
/// meanwhile).
pub fn fmu_path(model: &str, dir: &str) -> PathBuf {
    static PACKAGED: Mutex<Vec<(String, PathBuf)>> = Mutex::new(Vec::new());
    if let Some(released) = std::env::var_os("KALFMU_FMU_DIR") {
        return Path::new(&released).join(format!("{model}.fmu"));
    }
    let mut packaged = PACKAGED.lock().expect("the packaged FMUs");
    if let Some((_, path)) = packaged.iter().find(|(m, _)| m == model) {
        return path.clone();
    }
    let path = package(model, &Path::new(env!("CARGO_TARGET_TMPDIR")).join(dir));
    packaged.push((model.to_owned(), path.clone()));
    path
}

/// Writes `<model>.fmu` into `dir` with the layout `package-fmus` writes; stored
/// rather than deflated (deflating a 10 MB debug library in a debug build takes
/// seconds; importers read both).
fn package(model: &str, dir: &Path) -> PathBuf {
    let exe = std::env::current_exe().expect("the test executable's path");
    let deps = exe.parent().expect("the test executable is in target/<profile>/deps");
    let library = deps.join("libkalfmu_fmu.so");
    let binary = fs::read(&library)
        .unwrap_or_else(|e| panic!("{}: {e} (cargo builds the cdylib next to the test executable)", library.display()));
    let fmu = catalogue::all()
        .into_iter()
        .find(|f| f.description().model_identifier() == model)
        .unwrap_or_else(|| panic!("no FMU {model}"));
    let d = fmu.description();
    fs::create_dir_all(dir).expect("a directory for the packaged FMU");
    let path = dir.join(format!("{model}.fmu"));
    let mut zip = zip::ZipWriter::new(File::create(&path).expect("the .fmu file"));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    let (xml, html) = (model_description(d), d.documentation_page());
    let entries: [(String, &[u8]); 3] = [
        ("modelDescription.xml".into(), xml.as_bytes()),
        (format!("binaries/linux64/{model}.so"), &binary),
        ("documentation/index.html".into(), html.as_bytes()),
    ];
    for (name, bytes) in entries {
        zip.start_file(name.as_str(), options).expect("a zip entry");
        zip.write_all(bytes).expect("the zip entry's bytes");
    }
    zip.finish().expect("the finished .fmu");
    path
}
