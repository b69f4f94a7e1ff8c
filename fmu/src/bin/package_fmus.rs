//! Writes every FMU, the estimators and the plants: `modelDescription.xml`, the shared library as
//! `binaries/linux64/<modelIdentifier>.so`, and `documentation/index.html`.
//!
//! Usage:
//!   cargo run --release -p fmu --bin package-fmus [-- --out DIR]
//!   cargo run --release -p fmu --bin package-fmus -- --write-model-descriptions
//!
//! The library is the `libkalfmu_fmu.so` cargo builds beside this program.
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
    let library = exe.parent().ok_or("no directory of the executable")?.join("libkalfmu_fmu.so");
    let binary = fs::read(&library)
        .map_err(|e| format!("{}: {e} (build it with cargo build --release -p fmu)", library.display()))?;
    fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    for fmu in &catalogue::all() {
        let d = fmu.description();
        d.check()?;
        let path = out.join(format!("{}.fmu", d.model_identifier()));
        let file = File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut zip = zip::ZipWriter::new(file);
        let options = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
        let (xml, html) = (model_description(d), d.documentation_page());
        let entries: [(String, &[u8]); 3] = [
            ("modelDescription.xml".into(), xml.as_bytes()),
            (format!("binaries/linux64/{}.so", d.model_identifier()), &binary),
            ("documentation/index.html".into(), html.as_bytes()),
        ];
        for (name, bytes) in entries {
            zip.start_file(name.as_str(), options).map_err(|e| format!("{}: {name}: {e}", path.display()))?;
            zip.write_all(bytes).map_err(|e| format!("{}: {name}: {e}", path.display()))?;
        }
        zip.finish().map_err(|e| format!("{}: {e}", path.display()))?;
        println!("{}", path.display());
    }
    Ok(())
}
