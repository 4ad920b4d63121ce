//! The picture of a live frame in `docs/daemon.md` ("Live view in Foxglove"), made from a scene
//! drawn here, with no photo and no shared data (their licences keep them out of the repository).
//!
//! 1. Draw a 768x512 sRGB scene: sky, a wall, ground and three standing people (head, hair,
//!    shirt, arms, trousers, shoes), anti-aliased by 3x3 supersampling.
//! 2. Start `mosaicd run` on it, the way `tests/live_foxglove.rs` starts it on a photo: a `files`
//!    camera looping the scene at 10 frames/s (sampled to an RGGB mosaic), the built-in default
//!    model, and the live view on a free port (`preview_decimation = 1`).
//! 3. Connect as the Foxglove app does (the test's client, `tests/live_client/mod.rs`), subscribe
//!    to the preview and the annotations, and wait for an image and boxes of the same frame.
//! 4. Write that image, demosaiced (bilinear), with the boxes it received drawn on it, as a PNG,
//!    and print the boxes.
//!
//! ```sh
//! cargo build --bin mosaicd --example live_view_picture
//! target/debug/examples/live_view_picture docs/images/live-view.png
//! ```
//!
//! The daemon is the `mosaicd` next to the example's directory (`target/debug/mosaicd` above), or
//! `$MOSAICD_BIN`.

#[path = "../tests/live_client/mod.rs"]
mod live_client;

use std::path::{Path, PathBuf};

use foxglove::messages::{ImageAnnotations, RawImage};
use foxglove::Decode;
use mosaicd::image::Image;

/// Size of the scene (the size of Kodak's photos, as in the test).
const W: usize = 768;
const H: usize = 512;
/// Supersampling factor per side.
const SS: usize = 3;

/// A supersampled RGB canvas; shapes are painted in order, each given as a predicate on scene
/// coordinates (pixel centres of the final image at `x + 0.5`).
struct Canvas {
    px: Vec<[f32; 3]>,
}

impl Canvas {
    fn new(bg: impl Fn(f32, f32) -> [f32; 3]) -> Self {
        let px = (0..H * SS)
            .flat_map(|j| (0..W * SS).map(move |i| (i, j)))
            .map(|(i, j)| bg(sample(i), sample(j)))
            .collect();
        Self { px }
    }

    /// Paint `colour` where `inside(x, y)`, within the box `[x0, x1] x [y0, y1]`.
    fn fill(
        &mut self,
        (x0, y0, x1, y1): (f32, f32, f32, f32),
        colour: [u8; 3],
        inside: impl Fn(f32, f32) -> bool,
    ) {
        let range = |a: f32, b: f32, n: usize| {
            let lo = ((a * SS as f32).floor().max(0.0) as usize).min(n);
            let hi = ((b * SS as f32).ceil().max(0.0) as usize).min(n);
            lo..hi
        };
        let c = colour.map(f32::from);
        for j in range(y0, y1, H * SS) {
            for i in range(x0, x1, W * SS) {
                if inside(sample(i), sample(j)) {
                    self.px[j * W * SS + i] = c;
                }
            }
        }
    }

    /// An ellipse given by its bounding box.
    fn ellipse(&mut self, (x0, y0): (f32, f32), (x1, y1): (f32, f32), colour: [u8; 3]) {
        self.ellipse_part((x0, y0), (x1, y1), colour, false);
    }

    /// An ellipse given by its bounding box, or only its upper half.
    fn ellipse_part(&mut self, (x0, y0): (f32, f32), (x1, y1): (f32, f32), colour: [u8; 3], upper: bool) {
        let (cx, cy, rx, ry) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0, (x1 - x0) / 2.0, (y1 - y0) / 2.0);
        self.fill((x0, y0, x1, y1), colour, |x, y| {
            ((x - cx) / rx).powi(2) + ((y - cy) / ry).powi(2) <= 1.0 && (!upper || y <= cy)
        });
    }

    /// A thick polyline with round ends and joints.
    fn line(&mut self, pts: &[(f32, f32)], width: f32, colour: [u8; 3]) {
        let r = width / 2.0;
        for s in pts.windows(2) {
            let ((ax, ay), (bx, by)) = (s[0], s[1]);
            let bbox = (ax.min(bx) - r, ay.min(by) - r, ax.max(bx) + r, ay.max(by) + r);
            self.fill(bbox, colour, |x, y| {
                let (dx, dy) = (bx - ax, by - ay);
                let t = (((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
                (x - ax - t * dx).powi(2) + (y - ay - t * dy).powi(2) <= r * r
            });
        }
    }

    /// A convex polygon, corners in order.
    fn polygon(&mut self, pts: &[(f32, f32)], colour: [u8; 3]) {
        let bbox = pts
            .iter()
            .fold((f32::MAX, f32::MAX, f32::MIN, f32::MIN), |b, &(x, y)| {
                (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y))
            });
        self.fill(bbox, colour, |x, y| {
            let side = |k: usize| {
                let ((ax, ay), (bx, by)) = (pts[k], pts[(k + 1) % pts.len()]);
                (bx - ax) * (y - ay) - (by - ay) * (x - ax)
            };
            let first = side(0);
            (1..pts.len()).all(|k| side(k) * first >= 0.0)
        });
    }

    /// The final image: the mean of each `SS` x `SS` block, rounded.
    fn finish(&self) -> Image<[u8; 3]> {
        Image::from_fn(W, H, |x, y| {
            let mut sum = [0.0f32; 3];
            for j in 0..SS {
                for i in 0..SS {
                    let p = self.px[(y * SS + j) * W * SS + x * SS + i];
                    (0..3).for_each(|c| sum[c] += p[c]);
                }
            }
            sum.map(|v| (v / (SS * SS) as f32).round() as u8)
        })
    }
}

/// Scene coordinate of supersample `i`.
fn sample(i: usize) -> f32 {
    (i as f32 + 0.5) / SS as f32
}

/// A standing person `h` pixels tall, centred on `cx`, feet at `foot`; proportions in head
/// units (`h / 8`), legs apart by `stride` head units per unit of height below the hips.
struct Person {
    cx: f32,
    foot: f32,
    h: f32,
    shirt: [u8; 3],
    trousers: [u8; 3],
    stride: f32,
}

const SKIN: [u8; 3] = [205, 160, 130];
const HAIR: [u8; 3] = [50, 35, 25];
const SHOES: [u8; 3] = [40, 35, 35];

impl Person {
    fn draw(&self, c: &mut Canvas) {
        let u = self.h / 8.0;
        let p = |x: f32, y: f32| (self.cx + x * u, self.foot - self.h + y * u);
        for s in [-1.0f32, 1.0] {
            let fx = s * (0.45 + self.stride * 4.0);
            c.line(&[p(s * 0.35, 4.0), p(fx, 8.0)], 0.75 * u, self.trousers);
            c.ellipse(p(fx - 0.45, 7.75), p(fx + 0.45, 8.1), SHOES);
        }
        c.polygon(
            &[p(-1.0, 1.35), p(1.0, 1.35), p(0.8, 4.2), p(-0.8, 4.2)],
            self.shirt,
        );
        c.ellipse(p(-1.05, 1.2), p(-0.55, 1.9), self.shirt);
        c.ellipse(p(0.55, 1.2), p(1.05, 1.9), self.shirt);
        for s in [-1.0f32, 1.0] {
            c.line(
                &[p(s * 0.85, 1.55), p(s * 1.05, 3.0), p(s * 0.95, 4.0)],
                0.45 * u,
                self.shirt,
            );
            c.ellipse(p(s * 0.95 - 0.22, 3.85), p(s * 0.95 + 0.22, 4.3), SKIN);
        }
        let (nx0, ny0) = p(-0.2, 0.85);
        let (nx1, ny1) = p(0.2, 1.4);
        c.fill((nx0, ny0, nx1, ny1), SKIN, |_, _| true);
        c.ellipse(p(-0.42, 0.0), p(0.42, 1.0), SKIN);
        c.ellipse_part(p(-0.44, -0.04), p(0.44, 0.9), HAIR, true);
    }
}

/// The scene: sky above a horizon at 55 % of the height, a wall in front of it, ground below,
/// three people.
fn scene() -> Image<[u8; 3]> {
    let horizon = (H as f32 * 0.55).floor();
    let mut c = Canvas::new(|_, y| {
        let row = y.floor();
        if row < horizon {
            let t = row / horizon;
            [120.0 + 70.0 * t, 160.0 + 50.0 * t, 225.0 - 25.0 * t].map(f32::floor)
        } else {
            let t = (row - horizon) / (H as f32 - horizon);
            [150.0 + 40.0 * t, 140.0 + 35.0 * t, 110.0 + 25.0 * t].map(f32::floor)
        }
    });
    c.fill(
        (0.0, horizon - 60.0, W as f32, horizon),
        [165, 150, 140],
        |_, _| true,
    );
    let people = [
        (180.0, 470.0, 250.0, [200, 40, 40], [40, 50, 90], 0.12),
        (420.0, 440.0, 200.0, [40, 90, 170], [60, 60, 60], 0.05),
        (620.0, 485.0, 280.0, [230, 200, 60], [70, 55, 45], 0.09),
    ];
    for (cx, foot, h, shirt, trousers, stride) in people {
        Person {
            cx,
            foot,
            h,
            shirt,
            trousers,
            stride,
        }
        .draw(&mut c);
    }
    c.finish()
}

fn daemon_binary() -> PathBuf {
    if let Some(p) = std::env::var_os("MOSAICD_BIN") {
        return PathBuf::from(p);
    }
    let exe = std::env::current_exe().expect("the example's path");
    exe.parent()
        .and_then(Path::parent)
        .map(|d| d.join("mosaicd"))
        .expect("target/<profile>/mosaicd")
}

fn main() {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "docs/images/live-view.png".into()),
    );
    let dir = tempfile::tempdir().expect("a temporary directory");
    let picture = dir.path().join("people.png");
    let img = scene();
    let flat: Vec<u8> = img.into_vec().into_iter().flatten().collect();
    image::RgbImage::from_raw(W as u32, H as u32, flat)
        .expect("a whole image")
        .save(&picture)
        .expect("the scene written");
    let cfg = dir.path().join("live.toml");
    std::fs::write(&cfg, live_client::live_config("people", &picture, "", "")).expect("the config written");
    let bin = daemon_binary();
    eprintln!("starting {} on a drawn scene", bin.display());
    let mut daemon = live_client::spawn_daemon(&bin, &cfg);
    let rt = tokio::runtime::Runtime::new().expect("a runtime");
    let (img, dets) = rt.block_on(async {
        let mut ws = live_client::connect(&daemon.url, None).await;
        let ch = live_client::channels(&mut ws, &["/people/preview", "/people/annotations"]).await;
        live_client::subscribe(&mut ws, &[ch[0].0, ch[1].0]).await;
        let mut images = std::collections::BTreeMap::new();
        let mut boxes = std::collections::BTreeMap::new();
        loop {
            let (sub, t, payload) = live_client::next_data(&mut ws).await;
            match sub {
                1 => {
                    images.insert(t, RawImage::decode(payload.as_slice()).expect("a RawImage"));
                }
                _ => {
                    let a = ImageAnnotations::decode(payload.as_slice()).expect("ImageAnnotations");
                    boxes.insert(t, live_client::boxes(&a));
                }
            }
            let both = images
                .keys()
                .find(|t| boxes.get(t).is_some_and(|b| !b.is_empty()))
                .copied();
            if let Some(t) = both {
                break (images.remove(&t).unwrap(), boxes.remove(&t).unwrap());
            }
        }
    });
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(daemon.child.id() as i32, libc::SIGTERM) };
    let _ = daemon.child.wait();
    if let Some(parent) = out.parent() {
        std::fs::create_dir_all(parent).expect("the output directory");
    }
    live_client::write_picture(&img, &dets, &out);
    println!(
        "{}: a received {}x{} {} frame with {} boxes",
        out.display(),
        img.width,
        img.height,
        img.encoding,
        dets.len()
    );
    for d in &dets {
        println!(
            "  x {:6.1} y {:6.1} w {:6.1} h {:6.1}",
            d.x, d.y, d.width, d.height
        );
    }
}
