//! Multi-scale sliding-window detection: a scale pyramid, one HOG block grid per level, linear SVM
//! scores for every window (stride 8) read from the grid, then non-maximum suppression.
//!
//! ```
//! use mosaicd::detect::detector::{Detector, DetectorOptions};
//! use mosaicd::detect::model::{Domain, LinearModel};
//! use mosaicd::features::hog::HogInput;
//! use mosaicd::image::Image;
//! let mut w = vec![0.0f32; 3781];
//! w[3780] = -1.0; // bias: nothing fires
//! let model = LinearModel::from_opencv_vector(&w, Domain::Grey, "toy").unwrap();
//! let det = Detector::new(model, &DetectorOptions::default()).unwrap();
//! let img = Image::<u8>::filled(200, 300, 100);
//! let (boxes, stats) = det.detect(&HogInput::GreyU8(img.view())).unwrap();
//! assert!(boxes.is_empty());
//! assert_eq!(stats.levels, det.levels(200, 300, false).len());
//! ```
//!
//! # Method
//! Level `i` has scale `s_i = s_0 · step^i` (`s_0 = 1/upsample`), size `round(W/s_i) x round(H/s_i)`
//! (rounded to even for mosaics), stopping when a window no longer fits or after `max_levels`
//! levels — OpenCV `detectMultiScale`'s rule. Grey and colour levels are bilinear resizes (as
//! OpenCV); mosaic levels use the CFA-preserving super-pixel resize so mosaic gradients stay valid.
//! With `upsample > 1` the frame is first magnified to level 0's size (into buffers reused from
//! frame to frame) and every other level is resized from that magnified frame, as
//! `cv2.resize(img, u)` followed by `detectMultiScale` does. Levels of 8-bit input (grey u8, RGB)
//! are rounded to integers, as OpenCV keeps an 8-bit image's pyramid in 8 bits; f32, u16 and
//! mosaic input keep f32 levels.
//! A window at block (wx, wy) of a level scores `b + Σ_{bx<7, by<15} w_{bx,by} · B(wx+bx, wy+by)`
//! where `B` is the level's normalised block grid — each block is computed once per level, never per
//! window, and the sum is evaluated as one GEMM per block row ([`super::score`]). A hit (`score ≥ hit_threshold`) becomes the box `(8wx·s, 8wy·s, 64s, 128s)` in full-frame
//! pixels (rounded like OpenCV), then NMS merges hits.
//!
//! # Deviations from OpenCV
//! No window padding (OpenCV `detectMultiScale` pads by 0 by default for `winStride` 8 as well).
//! Pyramid levels are interpolated in f32 and then rounded (8-bit input); OpenCV interpolates in
//! 11-bit fixed point, so a level's pixels can differ by one grey level and only level 0 is
//! bit-comparable. Without the rounding, OpenCV's weights fired on 6 % more windows at the hit
//! threshold −0.5 on USC and lost 0.7 points of AP (docs/detection.md).
//!
//! # Layout
//!
//! This file holds [`Detector`] (levels, groups, lanes of approximated levels, scoring, NMS); below
//! it, importing nothing from it: `options` (the options, their checks, errors, [`Level`], stats),
//! `lanes` (which lane scores which approximated level), `scratch` (the bounded buffer pools) and
//! `planes` (the input's linear planes).

use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::model::{Domain, LinearModel};
use super::nms::{greedy_nms, group_rectangles};
use super::score::{
    window_scores, window_scores_i8, RowScorer, ScorePrecision, ScoreWeights, ScoreWeightsI8, ScorerBuffers,
};
use super::Detection;
use crate::features::hog::{
    approx_block_rows, block_and_micro_grids_from_gamma_planes, block_grid_dims,
    block_grid_from_gamma_planes, block_grid_stage_times, blocks_from_micro_grid, gamma_plane_into,
    micro_grid_from_gamma_planes, ApproxLevel, BlockGrid, Exec, GammaPlanes, HogError, HogInput, HogSpec,
    MicroGrid, CELL_SIZE, MICRO_CELL,
};
use crate::image::Image;
use crate::resize::resize_then;
use lanes::{approx_gain, deal_levels};
use planes::{linear_from_input, round_in_place, Linear, Plane, Planes};
use scratch::{ApproxScratch, LaneScratch, LevelScratch, Pool, ScratchPool};

mod lanes;
mod options;
mod planes;
mod scratch;

pub use options::{DetectError, DetectStats, DetectorOptions, DetectorSpec, Level, NmsMethod, StageProfile};

/// A ready-to-run detector: model, HOG spec and options.
#[derive(Debug, Clone)]
pub struct Detector {
    spec: DetectorSpec,
    hog: HogSpec,
    model: LinearModel,
    /// The model's weights laid out for the scoring GEMM.
    score_weights: ScoreWeights,
    /// The same quantised for the 8-bit path (only with `svm = I8`).
    score_weights_i8: Option<ScoreWeightsI8>,
    /// Level buffers reused across levels and frames.
    pool: ScratchPool,
    /// Buffers of the approximated levels' lanes (sweep rings and rows, window sums and products),
    /// reused the same way.
    lane_pool: Pool<LaneScratch>,
    /// Planes of magnified frames (`upsample > 1`), reused the same way.
    source_pool: Pool<Vec<Image<f32>>>,
}

impl Detector {
    /// The frame the pyramid is resized from: the input itself, or with `upsample > 1` the input
    /// first magnified to level 0's size (every plane, linear values, no gamma), so that every
    /// level is resized from the magnified frame as `cv2.resize(img, u) + detectMultiScale` resizes
    /// it; resizing each level straight from the input instead gives sharper levels that OpenCV's
    /// weights score lower (USC AP over seven phases 0.645 from the input, 0.648 from the
    /// magnified frame, docs/detection.md).
    fn source<'a>(
        &self,
        input: &HogInput<'a>,
        levels: &[Level],
        stats: &mut DetectStats,
    ) -> Result<Linear<'a>, DetectError> {
        let linear = linear_from_input(input);
        let Some(l0) = levels.first() else {
            return Ok(linear);
        };
        let (w, h) = input.dimensions();
        if (l0.width, l0.height) == (w, h) {
            return Ok(linear);
        }
        let t = Instant::now();
        let eight_bit = linear.eight_bit;
        // The magnified planes reuse a previous frame's buffers (a 1080p frame magnified 2x is
        // 33 MB of f32 per plane, too much to fault in afresh every frame).
        let mut bufs = self.source_pool.take().into_iter();
        let mut up = |p: &Plane, mosaic: bool| -> Result<Plane<'a>, DetectError> {
            let mut dst = bufs.next().unwrap_or_default();
            let op = move |row: &mut [f32]| {
                if eight_bit {
                    round_in_place(row)
                }
            };
            resize_then(p.view(), l0.width, l0.height, mosaic, &mut dst, &op)?;
            Ok(Plane::Owned(dst))
        };
        let planes = match &linear.planes {
            Planes::Grey(p) => Planes::Grey(up(p, false)?),
            Planes::Mosaic(p) => Planes::Mosaic(up(p, true)?),
            Planes::Colour([r, g, b]) => Planes::Colour([up(r, false)?, up(g, false)?, up(b, false)?]),
        };
        stats.resize += t.elapsed();
        Ok(Linear {
            planes,
            eight_bit,
            pooled: true,
        })
    }

    /// Hand the planes of a magnified frame back for the next one.
    fn recycle(&self, linear: Linear) {
        if !linear.pooled {
            return;
        }
        let own = |p: Plane| match p {
            Plane::Owned(i) => Some(i),
            Plane::Borrowed(_) => None,
        };
        let imgs: Vec<Image<f32>> = match linear.planes {
            Planes::Grey(p) | Planes::Mosaic(p) => own(p).into_iter().collect(),
            Planes::Colour(ps) => ps.into_iter().filter_map(own).collect(),
        };
        if !imgs.is_empty() {
            // At most as many frames in flight as level buffers: the same bound.
            self.source_pool.put_bounded(imgs, ScratchPool::capacity());
        }
    }

    /// Validate the model and options.
    pub fn new(model: LinearModel, opts: &DetectorOptions) -> Result<Self, DetectError> {
        let hog = model.hog_spec("detector model")?;
        let score_weights = ScoreWeights::new(&hog, &model.weights, model.bias)?;
        opts.svm.warn_if_slow();
        let score_weights_i8 = match opts.svm {
            ScorePrecision::F32 => None,
            ScorePrecision::I8 => Some(ScoreWeightsI8::new(&score_weights)?),
        };
        Ok(Self {
            spec: DetectorSpec::new(opts)?,
            hog,
            model,
            score_weights,
            score_weights_i8,
            pool: ScratchPool::default(),
            lane_pool: Pool::default(),
            source_pool: Pool::default(),
        })
    }
    /// The model.
    pub fn model(&self) -> &LinearModel {
        &self.model
    }
    /// The HOG spec.
    pub fn hog_spec(&self) -> &HogSpec {
        &self.hog
    }
    /// The options.
    pub fn spec(&self) -> &DetectorSpec {
        &self.spec
    }

    /// Pyramid levels for an input of `width x height` (mosaic sizes rounded to even).
    pub fn levels(&self, width: usize, height: usize, mosaic: bool) -> Vec<Level> {
        let o = &self.spec.opts;
        let (ww, wh) = (self.hog.win_width(), self.hog.win_height());
        let mut out = Vec::new();
        let mut scale = 1.0 / o.upsample;
        for _ in 0..o.max_levels {
            let (w, h) = if mosaic {
                (
                    2 * (width as f64 / scale / 2.0).round() as usize,
                    2 * (height as f64 / scale / 2.0).round() as usize,
                )
            } else {
                (
                    (width as f64 / scale).round() as usize,
                    (height as f64 / scale).round() as usize,
                )
            };
            if w < ww || h < wh {
                break;
            }
            out.push(Level {
                scale,
                width: w,
                height: h,
            });
            scale *= o.scale_step;
        }
        out
    }

    /// Detect in one frame (parallel over levels and rows in the current rayon pool).
    pub fn detect(&self, input: &HogInput) -> Result<(Vec<Detection>, DetectStats), DetectError> {
        self.detect_with(input, Exec::Parallel)
    }

    /// Size and kind of a frame the detector can take: `(width, height, is_mosaic)`, or the error
    /// naming why not (smaller than a window even after upsampling, or an odd-sized mosaic).
    fn check_input(&self, input: &HogInput) -> Result<(usize, usize, bool), DetectError> {
        let (w, h) = input.dimensions();
        let (ww, wh) = (self.hog.win_width(), self.hog.win_height());
        let up = self.spec.opts.upsample;
        if w == 0
            || h == 0
            || ((w as f64 * up).round() as usize) < ww
            || ((h as f64 * up).round() as usize) < wh
        {
            return Err(HogError::ImageTooSmall {
                width: w,
                height: h,
                win_width: ww,
                win_height: wh,
            }
            .into());
        }
        let mosaic = matches!(input, HogInput::Mosaic(_));
        if mosaic && (w % 2 != 0 || h % 2 != 0) {
            return Err(HogError::OddMosaic { width: w, height: h }.into());
        }
        Ok((w, h, mosaic))
    }

    /// One frame's detections with every stage run on the calling thread, one after another and
    /// **unfused**, each timed on its own: a diagnostic for `mosaicd bench detect`, whose
    /// production path fuses gradients, cells and blocks into one pass. Exact levels go through
    /// [`block_grid_stage_times`] (gradients, cells, blocks); each group's micro-cells, the
    /// approximated levels' cells and blocks (fused: built straight from the micro-cells), SVM and
    /// NMS are timed as the production path runs them. The detections equal
    /// [`Self::detect_serial`]'s; the times add up to more than a fused frame's CPU.
    pub fn stage_profile(&self, input: &HogInput) -> Result<(Vec<Detection>, StageProfile), DetectError> {
        let (w, h, mosaic) = self.check_input(input)?;
        let levels = self.levels(w, h, mosaic);
        let mut stats = DetectStats::default();
        let linear = self.source(input, &levels, &mut stats)?;
        let k = self.spec.opts.approx_levels.max(1);
        let mut prof = StageProfile {
            levels: levels.len(),
            ..Default::default()
        };
        let mut sc = LevelScratch::default();
        let mut a = ApproxScratch::default();
        let mut hits = Vec::new();
        for group in levels.chunks(k) {
            let head = &group[0];
            let planes = self.level_planes(&linear, head, &mut stats, &mut sc.planes)?;
            let t = block_grid_stage_times(&self.hog, &planes, &mut sc.blocks)?;
            prof.gradients += t.gradients;
            prof.cells += t.cells;
            prof.blocks += t.blocks;
            if group.len() > 1 {
                let t = Instant::now();
                micro_grid_from_gamma_planes(&self.hog, &planes, MICRO_CELL, Exec::Serial, &mut sc.micro)?;
                prof.micro_cells += t.elapsed();
            }
            let (d, s) = self.score_level(&sc.blocks, head, Exec::Serial, &mut sc.scores);
            hits.extend(d);
            prof.svm += s.svm;
            prof.windows += s.windows;
            for lv in &group[1..] {
                let t = Instant::now();
                self.approx_blocks(&sc.micro, head, lv, &mut a.blocks);
                prof.approx_cells_blocks += t.elapsed();
                let (d, s) = self.score_level(&a.blocks, lv, Exec::Serial, &mut a.scores);
                hits.extend(d);
                prof.svm += s.svm;
                prof.windows += s.windows;
            }
        }
        self.recycle(linear);
        prof.resize = stats.resize;
        prof.hits = hits.len();
        let t = Instant::now();
        let out = self.nms(hits);
        prof.nms = t.elapsed();
        Ok((out, prof))
    }

    /// The configured non-maximum suppression.
    fn nms(&self, hits: Vec<Detection>) -> Vec<Detection> {
        match self.spec.opts.nms {
            NmsMethod::None => hits,
            NmsMethod::Greedy { iou } => greedy_nms(&hits, iou),
            NmsMethod::Group { threshold, eps } => group_rectangles(&hits, threshold, eps),
        }
    }

    /// Every hit before NMS plus stats; `exec` picks parallel or serial.
    pub fn detect_raw(
        &self,
        input: &HogInput,
        exec: Exec,
    ) -> Result<(Vec<Detection>, DetectStats), DetectError> {
        let t0 = Instant::now();
        let (w, h, mosaic) = self.check_input(input)?;
        let levels = self.levels(w, h, mosaic);
        let mut up_stats = DetectStats::default();
        let linear = self.source(input, &levels, &mut up_stats)?;
        let k = self.spec.opts.approx_levels.max(1);
        let groups: Vec<&[Level]> = levels.chunks(k).collect();
        let run = |g: &&[Level]| self.detect_group(&linear, g, exec);
        let per_level: Vec<Result<(Vec<Detection>, DetectStats), DetectError>> = match exec {
            Exec::Parallel => groups.par_iter().map(run).collect(),
            Exec::Serial => groups.iter().map(run).collect(),
        };
        self.recycle(linear);
        let mut stats = DetectStats {
            levels: levels.len(),
            ..up_stats
        };
        let mut hits = Vec::new();
        for r in per_level {
            let (d, s) = r?;
            hits.extend(d);
            stats += s;
        }
        stats.hits = hits.len();
        stats.total = t0.elapsed();
        Ok((hits, stats))
    }

    fn detect_with(
        &self,
        input: &HogInput,
        exec: Exec,
    ) -> Result<(Vec<Detection>, DetectStats), DetectError> {
        let t0 = Instant::now();
        let (hits, mut stats) = self.detect_raw(input, exec)?;
        let t = Instant::now();
        let out = self.nms(hits);
        stats.nms = t.elapsed();
        stats.total = t0.elapsed();
        Ok((out, stats))
    }

    /// Serial detection (the oracle for the parallel path).
    pub fn detect_serial(&self, input: &HogInput) -> Result<(Vec<Detection>, DetectStats), DetectError> {
        self.detect_with(input, Exec::Serial)
    }

    /// Resize one level into `sc.planes` with gamma fused into each output row; the planes as HOG
    /// input.
    fn level_planes<'a>(
        &self,
        linear: &Linear,
        lv: &Level,
        stats: &mut DetectStats,
        planes: &'a mut [Image<f32>; 3],
    ) -> Result<GammaPlanes<'a>, DetectError> {
        let t = Instant::now();
        let gamma = self.hog.options().gamma_correction;
        let op = linear.level_row_op(gamma);
        let (srcs, mosaic): (&[Plane], bool) = match &linear.planes {
            Planes::Grey(p) => (std::slice::from_ref(p), false),
            Planes::Mosaic(p) => (std::slice::from_ref(p), true),
            Planes::Colour(ps) => (&ps[..], false),
        };
        // HOG takes colour planes in B, G, R order.
        for (src, dst) in srcs.iter().rev().zip(planes.iter_mut()) {
            let src = src.view();
            if (src.width(), src.height()) == (lv.width, lv.height) {
                gamma_plane_into(src, gamma, dst);
            } else {
                resize_then(src, lv.width, lv.height, mosaic, dst, &op)?;
            }
        }
        stats.resize += t.elapsed();
        let p = planes;
        Ok(match &linear.planes {
            Planes::Grey(_) => GammaPlanes::Grey(p[0].view()),
            Planes::Mosaic(_) => GammaPlanes::Mosaic(p[0].view()),
            Planes::Colour(_) => GammaPlanes::Colour([p[0].view(), p[1].view(), p[2].view()]),
        })
    }

    /// Exact block grid of one level into `sc.blocks`, cells and blocks fused (no cell grid); the
    /// time goes to `stats.hog.cells`.
    fn exact_blocks(
        &self,
        linear: &Linear,
        lv: &Level,
        exec: Exec,
        stats: &mut DetectStats,
        sc: &mut LevelScratch,
    ) -> Result<(), DetectError> {
        let planes = self.level_planes(linear, lv, stats, &mut sc.planes)?;
        let t = Instant::now();
        block_grid_from_gamma_planes(&self.hog, &planes, exec, &mut sc.blocks)?;
        stats.hog.cells += t.elapsed();
        Ok(())
    }

    /// One group of levels: the first is computed exactly, the others (approximate mode) from its
    /// micro-cells (the micro-cell pass recomputes the exact level's gradients; its time goes to
    /// `stats.hog.cells`).
    fn detect_group(
        &self,
        linear: &Linear,
        group: &[Level],
        exec: Exec,
    ) -> Result<(Vec<Detection>, DetectStats), DetectError> {
        let mut sc = self.pool.take();
        let r = self.detect_group_in(linear, group, exec, &mut sc);
        self.pool.put(sc);
        r
    }

    /// [`Self::detect_group`] with the level buffers `sc`.
    fn detect_group_in(
        &self,
        linear: &Linear,
        group: &[Level],
        exec: Exec,
        sc: &mut LevelScratch,
    ) -> Result<(Vec<Detection>, DetectStats), DetectError> {
        let mut stats = DetectStats::default();
        let mut dets = Vec::new();
        let Some(head) = group.first() else {
            return Ok((dets, stats));
        };
        if group.len() == 1 {
            self.exact_blocks(linear, head, exec, &mut stats, sc)?;
            let (d, s) = self.score_level(&sc.blocks, head, exec, &mut sc.scores);
            stats += s;
            return Ok((d, stats));
        }
        let planes = self.level_planes(linear, head, &mut stats, &mut sc.planes)?;
        let t = Instant::now();
        block_and_micro_grids_from_gamma_planes(
            &self.hog,
            &planes,
            MICRO_CELL,
            exec,
            &mut sc.blocks,
            &mut sc.micro,
        )?;
        stats.hog.cells += t.elapsed();
        let (d, s) = self.score_level(&sc.blocks, head, exec, &mut sc.scores);
        dets.extend(d);
        stats += s;
        // The approximated levels only read the micro-cells, so they are independent: in
        // parallel mode they are dealt to one lane per worker (balanced, `deal_levels`), and
        // each lane sweeps the micro grid once for all its levels, scoring every block row as it
        // is made (`approx_block_rows`, `RowScorer`: no block grid). Each level's arithmetic is
        // the same in any lane, and results are collected in level order: the same bits for any
        // thread count.
        let levels = &group[1..];
        let lanes = match exec {
            Exec::Parallel => rayon::current_num_threads().clamp(1, levels.len().max(1)),
            Exec::Serial => 1,
        };
        let micro = &sc.micro;
        let dealt = deal_levels(head, levels, lanes);
        let lane = |l: usize| -> Vec<(usize, Vec<Detection>, DetectStats)> {
            let mine = &dealt[l];
            let geoms: Vec<ApproxLevel> = mine
                .iter()
                .map(|&i| ApproxLevel {
                    width: levels[i].width,
                    height: levels[i].height,
                    gain: approx_gain(head, &levels[i]),
                })
                .collect();
            let mut held = self.lane_pool.take();
            held.scorers.resize_with(geoms.len(), ScorerBuffers::default);
            let mut scorers: Vec<RowScorer> = geoms
                .iter()
                .zip(held.scorers.iter_mut())
                .map(|(g, b)| {
                    let (nbx, nby) = block_grid_dims(g.width, g.height);
                    self.row_scorer(nbx, nby, std::mem::take(b))
                })
                .collect();
            let t = Instant::now();
            let mut svm = Duration::ZERO;
            approx_block_rows(&self.hog, micro, &geoms, &mut held.sweep, |j, _, row| {
                let t = Instant::now();
                scorers[j].push(row);
                svm += t.elapsed();
            });
            let mut scores = std::mem::take(&mut held.scores);
            let mut out = Vec::with_capacity(mine.len());
            for (k, (&i, scorer)) in mine.iter().zip(&scorers).enumerate() {
                let t1 = Instant::now();
                let (nwx, nwy) = scorer.windows();
                scores.clear();
                scores.resize(nwx * nwy, 0.0);
                scorer.finish(&mut scores);
                let mut s = DetectStats {
                    windows: nwx * nwy,
                    ..Default::default()
                };
                s.svm = t1.elapsed();
                if k == 0 {
                    // The lane's interleaved fill and scoring, counted once.
                    s.svm += svm;
                    s.cell_resample = t.elapsed().saturating_sub(svm);
                }
                out.push((i, self.detections_in(&scores, nwx, nwy, &levels[i]), s));
            }
            for (b, scorer) in held.scorers.iter_mut().zip(scorers) {
                *b = scorer.into_buffers();
            }
            held.scores = scores;
            self.lane_pool.put(held);
            out
        };
        let mut rest: Vec<(usize, Vec<Detection>, DetectStats)> = match exec {
            Exec::Parallel => (0..lanes).into_par_iter().map(lane).flatten().collect(),
            Exec::Serial => lane(0),
        };
        rest.sort_by_key(|r| r.0);
        for (_, d, s) in rest {
            dets.extend(d);
            stats += s;
        }
        Ok((dets, stats))
    }

    /// The blocks of approximated level `lv` from the micro-cells of its group's exact level
    /// `head`, on the calling thread.
    fn approx_blocks(&self, micro: &MicroGrid, head: &Level, lv: &Level, dst: &mut BlockGrid) {
        blocks_from_micro_grid(
            &self.hog,
            micro,
            lv.width,
            lv.height,
            approx_gain(head, lv),
            Exec::Serial,
            dst,
        );
    }

    fn score_level(
        &self,
        grid: &BlockGrid,
        lv: &Level,
        exec: Exec,
        scores: &mut Vec<f32>,
    ) -> (Vec<Detection>, DetectStats) {
        let mut stats = DetectStats::default();
        let t = Instant::now();
        let (nwx, nwy) = grid.windows(&self.hog);
        scores.clear();
        scores.resize(nwx * nwy, 0.0);
        self.window_scores(grid, exec, scores);
        stats.svm = t.elapsed();
        stats.windows = nwx * nwy;
        (self.detections_in(scores, nwx, nwy, lv), stats)
    }

    /// The detections among the `nwx x nwy` window `scores` of level `lv` (at or above the hit
    /// threshold), row-major.
    fn detections_in(&self, scores: &[f32], nwx: usize, nwy: usize, lv: &Level) -> Vec<Detection> {
        let thr = self.spec.opts.hit_threshold;
        let s = lv.scale;
        let (ww, wh) = (self.hog.win_width() as f64, self.hog.win_height() as f64);
        let mut dets = Vec::new();
        for wy in 0..nwy {
            for wx in 0..nwx {
                let sc = scores[wy * nwx + wx];
                if sc >= thr {
                    dets.push(Detection {
                        x: ((wx * CELL_SIZE) as f64 * s).round() as f32,
                        y: ((wy * CELL_SIZE) as f64 * s).round() as f32,
                        width: (ww * s).round() as f32,
                        height: (wh * s).round() as f32,
                        score: sc,
                    });
                }
            }
        }
        dets
    }

    /// Visit every window of the exact pyramid (levels in order, windows row-major) with its level,
    /// the level's block grid, its block position and its score. For training and evaluation.
    pub fn for_each_window(
        &self,
        input: &HogInput,
        mut f: impl FnMut(&Level, &BlockGrid, usize, usize, f32),
    ) -> Result<usize, DetectError> {
        let (w, h) = input.dimensions();
        let (ww, wh) = (self.hog.win_width(), self.hog.win_height());
        if w < ww || h < wh {
            return Err(HogError::ImageTooSmall {
                width: w,
                height: h,
                win_width: ww,
                win_height: wh,
            }
            .into());
        }
        let mosaic = matches!(input, HogInput::Mosaic(_));
        if mosaic && (w % 2 != 0 || h % 2 != 0) {
            return Err(HogError::OddMosaic { width: w, height: h }.into());
        }
        let levels = self.levels(w, h, mosaic);
        let mut stats = DetectStats::default();
        let linear = self.source(input, &levels, &mut stats)?;
        let mut sc = self.pool.take();
        let mut count = 0;
        for lv in levels {
            self.exact_blocks(&linear, &lv, Exec::Parallel, &mut stats, &mut sc)?;
            let grid = &sc.blocks;
            let scores = self.score_grid(grid);
            let (nwx, _) = grid.windows(&self.hog);
            for (i, &s) in scores.iter().enumerate() {
                f(&lv, grid, i % nwx, i / nwx, s);
            }
            count += scores.len();
        }
        self.pool.put(sc);
        self.recycle(linear);
        Ok(count)
    }

    /// Scores of every window of one block grid (row-major, `windows()` wide).
    pub fn score_grid(&self, grid: &BlockGrid) -> Vec<f32> {
        let (nwx, nwy) = grid.windows(&self.hog);
        let mut scores = vec![0.0f32; nwx * nwy];
        self.window_scores(grid, Exec::Parallel, &mut scores);
        scores
    }

    /// Window scores of one block grid with the configured precision ([`DetectorOptions::svm`]).
    fn window_scores(&self, grid: &BlockGrid, exec: Exec, scores: &mut [f32]) {
        match &self.score_weights_i8 {
            Some(q) => window_scores_i8(q, grid, exec, scores),
            None => window_scores(&self.score_weights, grid, exec, scores),
        }
    }

    /// A [`RowScorer`] of an `nbx x nby`-block grid with the configured precision (the same
    /// scores as [`Self::window_scores`]), in the allocations of `b`.
    fn row_scorer(&self, nbx: usize, nby: usize, b: ScorerBuffers) -> RowScorer<'_> {
        let isa = crate::kernels::isa();
        match &self.score_weights_i8 {
            Some(q) => RowScorer::i8_in(q, isa, nbx, nby, b),
            None => RowScorer::f32_in(&self.score_weights, isa, nbx, nby, b),
        }
    }

    /// The score of one window descriptor (OpenCV order) with the configured precision: the
    /// plain f32 dot product plus bias, or the 8-bit path's score (the same bits as the window's
    /// score in [`Self::score_grid`]).
    pub fn score_descriptor(&self, d: &[f32]) -> f32 {
        match &self.score_weights_i8 {
            Some(q) => q.score_descriptor(d),
            None => d.iter().zip(&self.model.weights).map(|(a, b)| a * b).sum::<f32>() + self.model.bias,
        }
    }
}

/// The input domain a [`HogInput`] belongs to.
pub fn domain_of(input: &HogInput) -> Domain {
    match input {
        HogInput::Mosaic(_) => Domain::Mosaic,
        HogInput::Rgb8(_) | HogInput::ColourF32(_) => Domain::Colour,
        _ => Domain::Grey,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::hog::block_grid;

    #[test]
    fn approximate_pyramid_scores_every_level_and_is_deterministic() {
        let exact = DetectorOptions {
            hit_threshold: -1e9,
            nms: NmsMethod::None,
            ..Default::default()
        };
        let approx = DetectorOptions {
            approx_levels: 5,
            ..exact
        };
        let img = Image::<u8>::from_fn(300, 400, |x, y| ((x * 5 + y * 3 + (x * y) / 7) % 256) as u8);
        let inp = HogInput::GreyU8(img.view());
        let de = Detector::new(model(5), &exact).unwrap();
        let da = Detector::new(model(5), &approx).unwrap();
        let (e, se) = de.detect(&inp).unwrap();
        let (a, sa) = da.detect(&inp).unwrap();
        let (b, _) = da.detect_serial(&inp).unwrap();
        assert_eq!(a, b);
        assert_eq!((se.windows, se.levels), (sa.windows, sa.levels));
        // Exact levels (every 5th, first one included) give identical boxes and scores.
        let lv0 = se.windows.min(e.len());
        let first_level = de.levels(300, 400, false)[0];
        let n0 = ((first_level.width / 8 - 7) * (first_level.height / 8 - 15)).min(lv0);
        assert_eq!(&e[..n0], &a[..n0]);
    }

    #[test]
    fn stage_profile_gives_the_serial_detections_and_times_every_stage() {
        let img = Image::<f32>::from_fn(420, 300, |x, y| ((x * 37 + y * 11 + (x * y) / 5) % 256) as f32);
        let inp = HogInput::Mosaic(img.view());
        for (approx, nms, svm) in [
            (1, NmsMethod::None, ScorePrecision::F32),
            (5, NmsMethod::Greedy { iou: 0.5 }, ScorePrecision::F32),
            (5, NmsMethod::None, ScorePrecision::I8),
        ] {
            let o = DetectorOptions {
                hit_threshold: -1.0,
                approx_levels: approx,
                nms,
                svm,
                ..Default::default()
            };
            let d = Detector::new(model(3), &o).unwrap();
            let (want, st) = d.detect_serial(&inp).unwrap();
            let (got, p) = d.stage_profile(&inp).unwrap();
            assert!(!want.is_empty());
            assert_eq!(got, want, "approx {approx}");
            assert_eq!((p.levels, p.windows, p.hits), (st.levels, st.windows, st.hits));
            // `cells` is the cell pass minus a separately timed gradient pass, so only their sum
            // is sure to be positive on a busy machine.
            for (name, t) in [
                ("gradients + cells", p.gradients + p.cells),
                ("blocks", p.blocks),
                ("svm", p.svm),
            ] {
                assert!(t > Duration::ZERO, "{name} approx {approx}");
            }
            assert_eq!(p.micro_cells > Duration::ZERO, approx > 1);
            assert_eq!(p.approx_cells_blocks > Duration::ZERO, approx > 1);
            assert!(p.total() >= p.svm + p.cells);
        }
        let tiny = Image::<u8>::new(32, 32);
        assert!(matches!(
            Detector::new(model(3), &DetectorOptions::default())
                .unwrap()
                .stage_profile(&HogInput::GreyU8(tiny.view())),
            Err(DetectError::Hog(HogError::ImageTooSmall { .. }))
        ));
    }

    #[test]
    fn i8_scores_are_deterministic_and_close_to_f32() {
        let img = Image::<f32>::from_fn(420, 300, |x, y| ((x * 37 + y * 11 + (x * y) / 5) % 256) as f32);
        let inp = HogInput::Mosaic(img.view());
        let f32_opts = DetectorOptions {
            hit_threshold: -1e9,
            nms: NmsMethod::None,
            approx_levels: 3,
            ..Default::default()
        };
        let i8_opts = DetectorOptions {
            svm: ScorePrecision::I8,
            ..f32_opts
        };
        let f = Detector::new(model(7), &f32_opts)
            .unwrap()
            .detect(&inp)
            .unwrap()
            .0;
        let d = Detector::new(model(7), &i8_opts).unwrap();
        let (q, _) = d.detect(&inp).unwrap();
        assert_eq!(q, d.detect_serial(&inp).unwrap().0);
        assert_eq!(q.len(), f.len());
        let bound = ScoreWeightsI8::new(&d.score_weights).unwrap().error_bound();
        let mut max = 0.0f32;
        for (a, b) in q.iter().zip(&f) {
            assert_eq!((a.x, a.y, a.width, a.height), (b.x, b.y, b.width, b.height));
            max = max.max((a.score - b.score).abs());
        }
        assert!(max > 0.0 && max <= bound, "max |Δ| {max}, bound {bound}");
        // Positives of the window protocol are scored the same way as the grid's windows.
        let spec = d.hog_spec().clone();
        let mut grid = BlockGrid::empty();
        block_grid(&spec, &inp, Exec::Serial, &mut grid).unwrap();
        let scores = d.score_grid(&grid);
        let desc = grid.window_descriptor(&spec, 2, 3).unwrap();
        let nwx = grid.windows(&spec).0;
        assert_eq!(d.score_descriptor(&desc).to_bits(), scores[3 * nwx + 2].to_bits());
    }

    fn model(seed: u32) -> LinearModel {
        let v: Vec<f32> = (0..3781u32)
            .map(|i| ((i.wrapping_mul(2654435761) ^ seed) % 1000) as f32 / 1000.0 - 0.5)
            .collect();
        LinearModel::from_opencv_vector(&v, Domain::Grey, "test").unwrap()
    }

    /// The planes of every level (gamma off, so they are the resized values themselves).
    fn level_values(d: &Detector, input: &HogInput) -> Vec<Image<f32>> {
        let (w, h) = input.dimensions();
        let mosaic = matches!(input, HogInput::Mosaic(_));
        let levels = d.levels(w, h, mosaic);
        let mut stats = DetectStats::default();
        let linear = d.source(input, &levels, &mut stats).unwrap();
        let mut planes: [Image<f32>; 3] = Default::default();
        levels
            .iter()
            .map(|lv| {
                d.level_planes(&linear, lv, &mut stats, &mut planes).unwrap();
                planes[0].clone()
            })
            .collect()
    }

    #[test]
    fn eight_bit_input_keeps_eight_bit_levels_and_upsampling_resizes_from_the_magnified_frame() {
        let mut m = model(3);
        m.gamma_correction = false;
        let opts = DetectorOptions {
            upsample: 1.5,
            ..Default::default()
        };
        let d = Detector::new(m, &opts).unwrap();
        let img = Image::<u8>::from_fn(150, 200, |x, y| ((x * 7 + y * 3 + x * y / 5) % 251) as u8);
        let f = img.map(|p| p as f32);
        let u8_levels = level_values(&d, &HogInput::GreyU8(img.view()));
        let f32_levels = level_values(&d, &HogInput::GreyF32(f.view()));
        assert!(u8_levels.len() > 3);
        // u8 input: every level holds integers (OpenCV keeps an 8-bit pyramid in 8 bits), each
        // the rounded f32 level; f32 input keeps the fractions.
        for (a, b) in u8_levels.iter().zip(&f32_levels).skip(1) {
            assert!(a.as_slice().iter().all(|v| v.fract() == 0.0));
            assert!(b.as_slice().iter().any(|v| v.fract() != 0.0));
        }
        // Level 0 is the magnified frame; level k is resized from it, not from the input.
        let levels = d.levels(150, 200, false);
        let resized = |src: &Image<f32>, lv: &Level, op: &crate::resize::RowOp| {
            let mut dst = Image::new(0, 0);
            resize_then(src.view(), lv.width, lv.height, false, &mut dst, op).unwrap();
            dst
        };
        let up = resized(&f, &levels[0], &|_| {});
        assert_eq!(f32_levels[0], up);
        assert_eq!(f32_levels[4], resized(&up, &levels[4], &|_| {}));
        assert_ne!(f32_levels[4], resized(&f, &levels[4], &|_| {}));
        // Rounding happens on the magnified frame too.
        let up8 = resized(&f, &levels[0], &round_in_place);
        assert_eq!(u8_levels[0], up8);
    }

    #[test]
    fn magnified_frames_reuse_their_buffers() {
        let opts = DetectorOptions {
            upsample: 2.0,
            hit_threshold: -1e9,
            ..Default::default()
        };
        let d = Detector::new(model(5), &opts).unwrap();
        let img = Image::<f32>::from_fn(96, 80, |x, y| ((x * 13 + y * 7) % 97) as f32);
        let first = d.detect(&HogInput::Mosaic(img.view())).unwrap().0;
        assert!(!first.is_empty());
        let ptr = d.source_pool.free.lock().unwrap()[0][0].as_slice().as_ptr();
        for _ in 0..5 {
            assert_eq!(d.detect(&HogInput::Mosaic(img.view())).unwrap().0, first);
        }
        {
            let free = d.source_pool.free.lock().unwrap();
            assert_eq!(free.len(), 1);
            assert_eq!(
                free[0][0].as_slice().as_ptr(),
                ptr,
                "the same buffer, not a new one"
            );
        }
        // Without magnification nothing is pooled (converted u8 planes are not kept).
        let d1 = Detector::new(model(5), &DetectorOptions::default()).unwrap();
        let g = Image::<u8>::from_fn(96, 160, |x, y| ((x * 5 + y) % 251) as u8);
        d1.detect(&HogInput::GreyU8(g.view())).unwrap();
        assert!(d1.source_pool.free.lock().unwrap().is_empty());
    }

    #[test]
    fn levels_follow_opencv_rule() {
        let d = Detector::new(model(1), &DetectorOptions::default()).unwrap();
        let l = d.levels(1920, 1080, false);
        assert_eq!(
            l[0],
            Level {
                scale: 1.0,
                width: 1920,
                height: 1080
            }
        );
        // 1080 / 1.05^n ≥ 128 → n ≤ 43.7
        assert_eq!(l.len(), 44);
        assert!(l.last().unwrap().height >= 128);
        let m = d.levels(1920, 1080, true);
        assert!(m.iter().all(|l| l.width % 2 == 0 && l.height % 2 == 0));
    }

    #[test]
    fn bad_options_and_small_images_are_errors() {
        let o = DetectorOptions {
            scale_step: 1.0,
            ..Default::default()
        };
        assert!(matches!(
            Detector::new(model(1), &o),
            Err(DetectError::BadOption {
                what: "scale_step",
                ..
            })
        ));
        let d = Detector::new(model(1), &DetectorOptions::default()).unwrap();
        let img = Image::<u8>::new(64, 100);
        assert!(matches!(
            d.detect(&HogInput::GreyU8(img.view())),
            Err(DetectError::Hog(HogError::ImageTooSmall { .. }))
        ));
        let img = Image::<f32>::new(0, 0);
        assert!(d.detect(&HogInput::Mosaic(img.view())).is_err());
        // With upsampling, an image shorter than a window is searched at the magnified levels.
        let up = DetectorOptions {
            upsample: 2.0,
            ..Default::default()
        };
        let d2 = Detector::new(model(1), &up).unwrap();
        let small = Image::<u8>::from_fn(64, 100, |x, y| ((x * 3 + y) % 256) as u8);
        let (_, st) = d2.detect(&HogInput::GreyU8(small.view())).unwrap();
        assert!(st.levels >= 1 && st.windows >= 1);
    }

    #[test]
    fn scores_equal_descriptor_dot_product() {
        let img = Image::<u8>::from_fn(150, 170, |x, y| ((x * 31 + y * 17 + x * y) % 256) as u8);
        let d = Detector::new(model(3), &DetectorOptions::default()).unwrap();
        let mut grid = BlockGrid::empty();
        block_grid(
            d.hog_spec(),
            &HogInput::GreyU8(img.view()),
            Exec::Serial,
            &mut grid,
        )
        .unwrap();
        let scores = d.score_grid(&grid);
        let (nwx, nwy) = grid.windows(d.hog_spec());
        assert_eq!((nwx, nwy), (11, 6));
        for wy in 0..nwy {
            for wx in 0..nwx {
                let desc = grid.window_descriptor(d.hog_spec(), wx, wy).unwrap();
                let want: f64 = desc
                    .iter()
                    .zip(&d.model().weights)
                    .map(|(&a, &b)| a as f64 * b as f64)
                    .sum::<f64>()
                    + d.model().bias as f64;
                assert!((scores[wy * nwx + wx] as f64 - want).abs() < 1e-4);
            }
        }
    }

    #[test]
    fn level_buffer_pool_is_bounded_and_stops_growing() {
        let d = Detector::new(model(2), &DetectorOptions::default()).unwrap();
        let img = Image::<f32>::from_fn(320, 260, |x, y| ((x * 7 + y * 3) % 200) as f32);
        let inp = HogInput::Mosaic(img.view());
        let held = |d: &Detector| {
            let free = d.pool.free.lock().unwrap();
            let bytes: usize = free
                .iter()
                .map(|s| {
                    let planes: usize = s.planes.iter().map(|p| p.as_slice().len()).sum();
                    let b = &s.blocks;
                    planes
                        + s.micro.cells_x() * s.micro.cells_y()
                        + b.blocks_x() * b.blocks_y() * b.block_len()
                })
                .sum();
            (free.len(), bytes)
        };
        let first = d.detect(&inp).unwrap();
        let after_one = held(&d);
        for _ in 0..3 {
            assert_eq!(d.detect(&inp).unwrap().0, first.0);
        }
        let after_four = held(&d);
        assert!(after_four.0 >= 1 && after_four.0 <= ScratchPool::capacity());
        assert!(after_four.1 <= after_one.1 * ScratchPool::capacity().max(1));
        // A clone starts empty and detects the same.
        let c = d.clone();
        assert_eq!(held(&c).0, 0);
        assert_eq!(c.detect(&inp).unwrap().0, first.0);
    }

    #[test]
    fn levels_are_dealt_to_lanes_by_work() {
        let lv = |k: i32| {
            let r = 1.05f64.powi(-k);
            Level {
                scale: 1.0 / r,
                width: (1920.0 * r) as usize,
                height: (1080.0 * r) as usize,
            }
        };
        let levels: Vec<Level> = (1..14).map(lv).collect();
        let head = lv(0);
        let work = |ix: &[usize]| {
            ix.iter()
                .map(|&i| 0.35 + (levels[i].width * levels[i].height) as f64 / (1920.0 * 1080.0))
                .sum::<f64>()
        };
        for lanes in 1..=4 {
            let d = deal_levels(&head, &levels, lanes);
            let mut all: Vec<usize> = d.concat();
            all.sort();
            assert_eq!(all, (0..13).collect::<Vec<_>>(), "every level once");
            assert!(d.iter().all(|l| l.windows(2).all(|w| w[0] < w[1])), "ascending");
            let loads: Vec<f64> = d.iter().map(|l| work(l)).collect();
            let (lo, hi) = (
                loads.iter().cloned().fold(f64::MAX, f64::min),
                loads.iter().cloned().fold(0.0, f64::max),
            );
            // Within the smallest level's work of each other.
            assert!(hi - lo <= work(&[12]) + 1e-9, "{lanes} lanes: {loads:?}");
        }
    }

    #[test]
    fn approximated_levels_in_lanes_equal_serial_for_any_thread_count() {
        // Approximated levels are dealt to one lane per worker (1, 2 or 3 lanes for 5 levels a
        // group): the same hits, in the same order, as serially.
        let o = DetectorOptions {
            hit_threshold: -1e9,
            nms: NmsMethod::None,
            approx_levels: 6,
            ..Default::default()
        };
        let d = Detector::new(model(3), &o).unwrap();
        let img = Image::<f32>::from_fn(400, 300, |x, y| ((x * 5 + y * y) % 230) as f32);
        let inp = HogInput::Mosaic(img.view());
        let (serial, _) = d.detect_serial(&inp).unwrap();
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for _ in 0..2 {
                let (par, st) = pool.install(|| d.detect(&inp)).unwrap();
                assert_eq!(par, serial, "{threads} threads");
                assert!(st.levels > 6 && par.len() == st.windows);
                // Lane buffers are kept for the next frame, a bounded number of them.
                let held = d.lane_pool.free.lock().unwrap().len();
                assert!(
                    (1..=2 * threads.max(2)).contains(&held),
                    "{held} lane buffers held"
                );
            }
        }
    }

    #[test]
    fn parallel_equals_serial_all_domains() {
        let o = DetectorOptions {
            hit_threshold: -1e9,
            nms: NmsMethod::None,
            ..Default::default()
        };
        let d = Detector::new(model(7), &o).unwrap();
        let grey = Image::<u8>::from_fn(220, 260, |x, y| ((x * x + 7 * y) % 256) as u8);
        let mosaic = grey.map(|p| p as f32 * 0.9);
        let rgb = Image::<[u8; 3]>::from_fn(220, 260, |x, y| {
            [(x % 256) as u8, (y % 256) as u8, ((x ^ y) % 256) as u8]
        });
        for inp in [
            HogInput::GreyU8(grey.view()),
            HogInput::Mosaic(mosaic.view()),
            HogInput::Rgb8(rgb.view()),
        ] {
            let (a, sa) = d.detect(&inp).unwrap();
            let (b, sb) = d.detect_serial(&inp).unwrap();
            assert_eq!(a, b);
            assert_eq!((sa.levels, sa.windows), (sb.levels, sb.windows));
            assert!(sa.windows > 0 && a.len() == sa.windows);
        }
    }
}
