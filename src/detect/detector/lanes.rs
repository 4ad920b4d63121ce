//! The lanes of approximated levels: which lane scores which level of a group, and the cells' gain of an approximated level.

use super::options::Level;

/// Gain of the cells of level `lv` approximated from the micro-cells of `head`: the linear size
/// ratio `√(r_x r_y)` (summed gradient magnitudes measure edge length, which shrinks with the
/// level; see [`crate::features::hog::blocks_from_micro_grid`]).
pub(super) fn approx_gain(head: &Level, lv: &Level) -> f32 {
    ((lv.width * lv.height) as f64 / (head.width * head.height) as f64).sqrt() as f32
}

/// The approximated `levels` of a group (exact level `head`) dealt to `lanes` lanes, each lane's
/// level indices ascending: largest first, each to the lane with the least work so far, work
/// taken as `0.35 + area ratio` (the fill's pass over every micro-cell costs the same for any level,
/// about a third of a full-size level's fill, blocks and products; the rest scales with the
/// level's area). Depends only on the geometry, so the same for every frame; results do not
/// depend on it (each level's arithmetic is its own).
pub(super) fn deal_levels(head: &Level, levels: &[Level], lanes: usize) -> Vec<Vec<usize>> {
    let lanes = lanes.max(1);
    let area = (head.width * head.height).max(1) as f64;
    let mut load = vec![0.0f64; lanes];
    let mut dealt = vec![Vec::new(); lanes];
    // Levels come largest first.
    for (i, lv) in levels.iter().enumerate() {
        let l = (0..lanes)
            .min_by(|&a, &b| load[a].total_cmp(&load[b]))
            .expect("at least one lane");
        load[l] += 0.35 + (lv.width * lv.height) as f64 / area;
        dealt[l].push(i);
    }
    dealt
}
