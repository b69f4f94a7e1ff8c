//! Writes every FMU, the estimators and the plants: `modelDescription.xml`, the shared library as
//! `binaries/linux64/<modelIdentifier>.so` and, when there is a Windows build of it,
//! `binaries/win64/<modelIdentifier>.dll`, and `documentation/index.html`. One
//! modelDescription serves both platforms.
//!
//! Usage:
//!   cargo run --release -p fmu --bin package-fmus [-- --out DIR]
//!   cargo run --release -p fmu --bin package-fmus -- --write-model-descriptions
//!
//! The linux64 library is the `libkalfmu_fmu.so` cargo builds beside this program; the
//! win64 one is `kalfmu_fmu.dll` of `cargo build --release -p fmu --lib --target
//! x86_64-pc-windows-gnu`, taken only when it is at least as new as the linux64 one (an
//! older one is of older sources). Without it the FMUs hold linux64 only, and this says so.
//! `--write-model-descriptions` regenerates the committed `modelDescription/`
//! files instead (a test fails while they differ from the table).

use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use kalfmu_fmu::catalogue;
use kalfmu_fmu::model_description::model_description;
use zip::write::SimpleFileOptions;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().ok_or("no workspace root")?.to_path_buf();
    if args.iter().any(|a| a == "--write-model-descriptions") {
        for fmu in &catalogue::all() {
            let d = fmu.description();
            let dir = root.join("modelDescription").join(d.model_identifier());
            fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            let path = dir.join("modelDescription.xml");
            fs::write(&path, model_description(d)).map_err(|e| format!("{}: {e}", path.display()))?;
            println!("wrote {}", path.display());
        }
        return Ok(());
    }
    let out = match args.iter().position(|a| a == "--out") {
        Some(i) => PathBuf::from(args.get(i + 1).ok_or("--out needs a directory")?),
        None => root.join("target").join("fmu"),
    };
    if let Some(unknown) =
        args.iter().enumerate().find(|(i, a)| a.as_str() != "--out" && (*i == 0 || args[i - 1] != "--out"))
    {
        return Err(format!(
            "unknown argument '{}'; usage: package-fmus [--out DIR] | --write-model-descriptions",
            unknown.1
        ));
    }
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let exe_dir = exe.parent().ok_or("no directory of the executable")?;
    let library = exe_dir.join("libkalfmu_fmu.so");
    let binary = fs::read(&library)
        .map_err(|e| format!("{}: {e} (build it with cargo build --release -p fmu)", library.display()))?;
    let windows = windows_library(exe_dir, &library);
    match &windows {
        Ok(_) => println!("binaries: linux64 and win64"),
        Err(why) => println!("binaries: linux64 only: {why}"),
    }
    fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    for fmu in &catalogue::all() {
        let d = fmu.description();
        d.check()?;
        let path = out.join(format!("{}.fmu", d.model_identifier()));
        let file = File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut zip = zip::ZipWriter::new(file);
        let options = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
        let (xml, html) = (model_description(d), d.documentation_page());
        let mut entries: Vec<(String, &[u8])> = vec![
            ("modelDescription.xml".into(), xml.as_bytes()),
            (format!("binaries/linux64/{}.so", d.model_identifier()), &binary),
        ];
        if let Ok(dll) = &windows {
            entries.push((format!("binaries/win64/{}.dll", d.model_identifier()), dll));
        }
        entries.push(("documentation/index.html".into(), html.as_bytes()));
        for (name, bytes) in entries {
            zip.start_file(name.as_str(), options).map_err(|e| format!("{}: {name}: {e}", path.display()))?;
            zip.write_all(bytes).map_err(|e| format!("{}: {name}: {e}", path.display()))?;
        }
        zip.finish().map_err(|e| format!("{}: {e}", path.display()))?;
        println!("{}", path.display());
    }
    Ok(())
}

/// The Windows build of the library (`<target>/x86_64-pc-windows-gnu/<profile>/kalfmu_fmu.dll`
/// beside `<target>/<profile>/`, where this program is), or why there is none to package.
fn windows_library(exe_dir: &Path, linux: &Path) -> Result<Vec<u8>, String> {
    let profile = exe_dir.file_name().ok_or("no profile directory")?;
    let target = exe_dir.parent().ok_or("no target directory")?;
    let dll = target.join("x86_64-pc-windows-gnu").join(profile).join("kalfmu_fmu.dll");
    let build = "cargo build --release -p fmu --lib --target x86_64-pc-windows-gnu";
    let modified = |p: &Path| fs::metadata(p).and_then(|m| m.modified());
    let dll_time = modified(&dll).map_err(|_| format!("no {} (build it with {build})", dll.display()))?;
    let linux_time = modified(linux).map_err(|e| format!("{}: {e}", linux.display()))?;
    if dll_time < linux_time {
        return Err(format!(
            "{} is older than {}: of older sources; rebuild it with {build}",
            dll.display(),
            linux.display()
        ));
    }
    fs::read(&dll).map_err(|e| format!("{}: {e}", dll.display()))
}
