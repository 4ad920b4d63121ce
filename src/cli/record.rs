//! `mosaicd record`: make a recording (MCAP, our schemas) from a recipe, a V4L2 camera, or raw
//! files / RGB images with a camera motion.
//!
//! ```text
//! mosaicd record --recipe recordings/demo.toml                 # rebuild recordings/out/demo.mcap
//! mosaicd record --device /dev/video0 --frames 300 -o cam.mcap # a live camera
//! mosaicd record frames/ --sidecar frames/mosaicd-raw.toml -o files.mcap   # raw files as a stream
//! mosaicd record kodim12.png --crop 512x384 --path 0,0:255,127 --noise low --frames 30 -o pan.mcap
//! ```

use std::path::PathBuf;

use anyhow::{bail, Context};

use mosaicd::capture::parse_fourcc;
use mosaicd::capture::Source;
use mosaicd::capture::{FileSource, FileSourceOptions, Sidecar};
use mosaicd::capture::{V4l2Options, V4l2Source};
use mosaicd::clock::WallClockSource;
use mosaicd::progress::Progress;
use mosaicd::raw::Levels;
use mosaicd::record::{build_recording, Align, Motion, Recipe, RecipeRecorder, SourceSpec};
use mosaicd::record::{FlushPolicy, McapRecorder, PreviewOptions, RecorderOptions, RotatePolicy};

/// Arguments of `mosaicd record`.
#[derive(clap::Args, Debug)]
pub struct RecordArgs {
    /// Raw files / directories (played in order) or one image/raw file with `--crop` motion.
    pub inputs: Vec<PathBuf>,
    /// Build the recording a recipe describes (recordings/*.toml).
    /// Everything but `--out` and `--data` comes from the recipe file, so the other flags are
    /// refused with it rather than ignored.
    #[arg(long, conflicts_with_all = [
        "device", "inputs", "frames", "fps", "fourcc", "black", "white", "sidecar", "crop", "path",
        "even", "noise", "seed", "profile", "cfa", "bit_depth", "camera", "preview_decimation",
        "compression_level", "flush_frames", "rotate_mb", "rotate_secs",
    ])]
    pub recipe: Option<PathBuf>,
    /// Record a V4L2 camera (e.g. /dev/video0).
    #[arg(long, conflicts_with = "inputs")]
    pub device: Option<PathBuf>,
    /// Output file (default: the recipe's output, else out/recording.mcap).
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Data root for recipe files (default: $MOSAICD_DATA).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Frames to record (camera: required; files: default all; motion: default 30).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Frame rate (timestamps of files/motion; requested rate of a camera).
    #[arg(long)]
    pub fps: Option<f64>,
    /// Camera, motion and recorder options.
    #[command(flatten)]
    pub opts: Box<RecordOptions>,
}

/// The less common options of `mosaicd record` (boxed to keep the CLI enum small).
#[derive(clap::Args, Debug)]
pub struct RecordOptions {
    /// Preferred camera FourCC (e.g. pRAA, RG12).
    #[arg(long)]
    pub fourcc: Option<String>,
    /// Sensor black level (camera) — V4L2 does not report it.
    #[arg(long)]
    pub black: Option<u16>,
    /// Sensor white level (camera).
    #[arg(long)]
    pub white: Option<u16>,
    /// Sidecar TOML for every raw file.
    #[arg(long)]
    pub sidecar: Option<PathBuf>,
    /// Camera motion: crop window WxH moved along --path over one still input.
    #[arg(long)]
    pub crop: Option<String>,
    /// Crop-window waypoints "x0,y0:x1,y1:..." (default 0,0).
    #[arg(long, default_value = "0,0")]
    pub path: String,
    /// Keep crop offsets even (the pattern phase never changes); default any offset.
    #[arg(long)]
    pub even: bool,
    /// Noise preset for motion recordings: none, low, medium, high.
    #[arg(long, default_value = "none")]
    pub noise: String,
    /// Seed (noise, synthetic scenes).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Camera profile (config/cameras stem) for RGB images through the reverse ISP.
    #[arg(long)]
    pub profile: Option<String>,
    /// Output pattern for RGB images.
    #[arg(long)]
    pub cfa: Option<String>,
    /// Output bit depth for RGB images.
    #[arg(long)]
    pub bit_depth: Option<u8>,
    /// Camera name (topics /<camera>/raw, ...).
    #[arg(long, default_value = "camera")]
    pub camera: String,
    /// Preview decimation (0 = no preview).
    #[arg(long, default_value_t = 2)]
    pub preview_decimation: u32,
    /// zstd compression level (1 fast; 3 smaller for 8-bit data).
    #[arg(long, default_value_t = mosaicd::record::DEFAULT_COMPRESSION_LEVEL)]
    pub compression_level: u32,
    /// Flush every N frames (bounds what a crash loses).
    #[arg(long, default_value_t = 30)]
    pub flush_frames: u32,
    /// Start a new file after this many MiB (0 = never).
    #[arg(long)]
    pub rotate_mb: Option<u64>,
    /// Start a new file after this many seconds of recorded time (0 = never).
    #[arg(long)]
    pub rotate_secs: Option<u64>,
}

fn recorder_options(a: &RecordArgs) -> RecorderOptions {
    RecorderOptions {
        camera: a.opts.camera.clone(),
        compression_level: a.opts.compression_level,
        flush: FlushPolicy {
            every_frames: Some(a.opts.flush_frames.max(1)),
            every_ns: None,
        },
        rotate: RotatePolicy::from_limits(a.opts.rotate_mb, a.opts.rotate_secs),
        preview: (a.opts.preview_decimation > 0).then_some(PreviewOptions {
            decimation: a.opts.preview_decimation,
        }),
        // Frames only: no result channels that would hold no message.
        results: false,
        ..Default::default()
    }
}

fn parse_size(s: &str) -> anyhow::Result<(usize, usize)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .with_context(|| format!("--crop {s:?}: expected WxH"))?;
    Ok((w.trim().parse()?, h.trim().parse()?))
}

fn parse_path(s: &str) -> anyhow::Result<Vec<[usize; 2]>> {
    s.split(':')
        .map(|p| {
            let (x, y) = p
                .split_once(',')
                .with_context(|| format!("--path point {p:?}: expected x,y"))?;
            Ok([x.trim().parse()?, y.trim().parse()?])
        })
        .collect()
}

/// A frames bar for `total` frames (a counter when unknown); drawn only on a terminal.
fn frames_bar(total: Option<u64>) -> Progress {
    Progress::new("record", total)
}

fn record_source(
    a: &RecordArgs,
    mut src: Box<dyn Source>,
    limit: Option<u64>,
    out: PathBuf,
) -> anyhow::Result<()> {
    let opts = RecorderOptions {
        // A camera stamps frames with CLOCK_MONOTONIC: each file records the wall clock.
        wall_clock: a.device.is_some().then_some(WallClockSource::System),
        ..recorder_options(a)
    };
    let mut rec = McapRecorder::create(&out, opts)?;
    let bar = frames_bar(limit);
    let mut n = 0u64;
    let mut errors = 0u64;
    while limit.is_none_or(|l| n < l) {
        match src.next_frame() {
            Ok(Some(f)) => {
                rec.write_frame(&f)?;
                n += 1;
                bar.set(n, "frames");
            }
            Ok(None) => break,
            Err(e) if !src.is_finished() => {
                errors += 1;
                bar.println(&format!("  skipped: {e}"));
            }
            Err(e) => return Err(e.into()),
        }
    }
    bar.finish();
    let s = rec.finish()?;
    if n == 0 {
        // An empty recording is not a success: every input was skipped (or there was none).
        bail!(
            "nothing was recorded from {} ({errors} skipped): {} holds no frame",
            src.describe(),
            joined(&s.files)
        );
    }
    println!(
        "recorded {n} frames from {} ({errors} skipped) into {}",
        src.describe(),
        joined(&s.files)
    );
    Ok(())
}

/// The files of a recording, comma-separated (more than one when it rotated).
fn joined(files: &[PathBuf]) -> String {
    files
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

fn print_files(frames: u64, files: &[PathBuf]) {
    println!("recorded {frames} frames into {}", joined(files));
}

/// Run `mosaicd record`.
pub fn run(a: RecordArgs) -> anyhow::Result<()> {
    let data_root = match a.data.clone() {
        Some(d) => d,
        None => mosaicd::data::data_root_for("the recipe's source files")?,
    };
    if let Some(recipe_path) = &a.recipe {
        let recipe = Recipe::load(recipe_path)?;
        eprintln!(
            "building {} ({} frames) from {}",
            recipe.name,
            recipe.frames,
            recipe_path.display()
        );
        let bar = frames_bar(Some(recipe.frames));
        let progress = |done, _| bar.set(done, "frames");
        let s = build_recording(&recipe, &data_root, a.out.as_deref(), progress).with_context(|| {
            format!(
                "recipe {} (data root {})",
                recipe_path.display(),
                data_root.display()
            )
        })?;
        bar.finish();
        print_files(s.frames, &s.files);
        return Ok(());
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/recording.mcap"));
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    if let Some(dev) = &a.device {
        let Some(frames) = a.frames else {
            bail!("--device needs --frames N");
        };
        let fourcc = match &a.opts.fourcc {
            Some(f) => {
                Some(parse_fourcc(f).with_context(|| format!("--fourcc {f:?}: expected 4 characters"))?)
            }
            None => None,
        };
        let levels = match (a.opts.black, a.opts.white) {
            (None, None) => None,
            (b, w) => Some(Levels::uniform(
                b.unwrap_or(0),
                w.context("--black needs --white")?,
            )),
        };
        let opts = V4l2Options {
            fourcc,
            fps: a.fps.map(|f| f.round() as u32),
            levels,
            ..Default::default()
        };
        let src = V4l2Source::open(dev, opts)?;
        return record_source(&a, Box::new(src), Some(frames), out);
    }
    if a.inputs.is_empty() {
        bail!("nothing to record: give --recipe FILE, --device /dev/videoN, or input files");
    }
    if let Some(crop) = &a.opts.crop {
        let [input] = a.inputs.as_slice() else {
            bail!("--crop takes exactly one still input");
        };
        let (w, h) = parse_size(crop)?;
        let ext = input
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .unwrap_or_default();
        let rgb = matches!(ext.as_str(), "png" | "jpg" | "jpeg" | "bmp") && a.opts.sidecar.is_none();
        let format = match &a.opts.sidecar {
            Some(s) => Some(Sidecar::load(s)?),
            None => None,
        };
        let recipe = Recipe {
            name: input.display().to_string(),
            output: out.clone(),
            frames: a.frames.unwrap_or(30),
            fps: a.fps.unwrap_or(30.0),
            seed: a.opts.seed,
            noise: a.opts.noise.clone(),
            camera: a.opts.camera.clone(),
            source: SourceSpec {
                kind: if rgb { "rgb" } else { "raw" }.into(),
                file: Some(std::path::absolute(input)?),
                files: Vec::new(),
                scale: None,
                format,
                profile: a.opts.profile.clone(),
                cfa: a.opts.cfa.clone(),
                bit_depth: a.opts.bit_depth,
                width: None,
                height: None,
            },
            motion: Motion {
                width: w,
                height: h,
                waypoints: parse_path(&a.opts.path)?,
                align: if a.opts.even { Align::Even } else { Align::Any },
            },
            recorder: RecipeRecorder {
                preview_decimation: a.opts.preview_decimation,
                flush_frames: a.opts.flush_frames,
                compression_level: a.opts.compression_level,
                rotate_mb: a.opts.rotate_mb,
                rotate_secs: a.opts.rotate_secs,
            },
        };
        let bar = frames_bar(Some(recipe.frames));
        let progress = |done, _| bar.set(done, "frames");
        let s = build_recording(&recipe, std::path::Path::new("/"), Some(&out), progress)?;
        bar.finish();
        print_files(s.frames, &s.files);
        return Ok(());
    }
    let opts = FileSourceOptions {
        fps: a.fps.unwrap_or(mosaicd::capture::DEFAULT_FPS),
        sidecar: a.opts.sidecar.clone(),
        ..Default::default()
    };
    let src = FileSource::open(&a.inputs, opts)?;
    record_source(&a, Box::new(src), a.frames, out)
}
