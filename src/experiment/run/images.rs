//! The images of a run beside its rows: equal-budget strips (every strategy side by side,
//! then the reference) and the equal-spp progression grid of each scene.

use super::*;
use crate::error::Result;
use crate::experiment::config::Experiment;
use crate::film::{image_strip, read_exr, write_png};
use crate::report::rows::{BUDGET_SECONDS, BUDGET_SPP, Row};
use std::path::Path;

/// With a non-zero `exposure`, every checkpoint's preview PNG again from its EXR at that
/// exposure (the cached cells keep theirs at 0: the exposure is not part of a cell). Each
/// preview is replaced atomically, so the cell's hard-linked file is never written through.
pub(super) fn write_previews(exp: &Experiment, rows: &[Row], dir: &Path) -> Result<()> {
    if exp.exposure == 0.0 {
        return Ok(());
    }
    for r in rows {
        let exr = dir.join(&r.image);
        write_png(&read_exr(&exr)?, &exr.with_extension("png"), exp.exposure)?;
    }
    Ok(())
}

/// Per scene, at the largest spp checkpoint and at the largest time budget: the first seed's
/// image of every strategy side by side, then the reference ([`crate::report::html::strip_path`]).
pub(super) fn write_strips(exp: &Experiment, prepared: &[Prepared], rows: &[Row], dir: &Path) -> Result<()> {
    let Some(&seed) = exp.seeds.first() else { return Ok(()) };
    let checkpoints = [
        (BUDGET_SPP, exp.spp.last().map(|&s| s as f64)),
        (BUDGET_SECONDS, exp.seconds.last().copied()),
    ];
    for p in prepared {
        for (budget, value) in checkpoints {
            let Some(value) = value else { continue };
            let mut images = Vec::new();
            for spec in &exp.strategies {
                let row = rows.iter().find(|r| {
                    r.scene == p.scene.name
                        && r.strategy == spec.label
                        && r.seed == seed
                        && r.budget == budget
                        && r.budget_value == value
                });
                if let Some(r) = row {
                    images.push(read_exr(&dir.join(&r.image))?);
                }
            }
            let mut all: Vec<&crate::film::Image> = images.iter().collect();
            all.push(&p.reference.image);
            let strip = image_strip(&all, 2);
            let path = dir.join(crate::report::html::strip_path(&p.scene.name, budget, value));
            write_png(&strip, &path, exp.exposure)?;
        }
        write_progression(exp, p, rows, seed, dir)?;
    }
    Ok(())
}

/// The equal-spp progression of one scene ([`crate::report::html::progression_path`]), when the
/// experiment has two spp checkpoints or more. A strategy without some checkpoint leaves that
/// place black.
pub(super) fn write_progression(exp: &Experiment, p: &Prepared, rows: &[Row], seed: u64, dir: &Path) -> Result<()> {
    if exp.spp.len() < 2 {
        return Ok(());
    }
    let (w, h) = (p.reference.image.width, p.reference.image.height);
    let blank = crate::film::Image::new(w, h);
    let mut images: Vec<Vec<crate::film::Image>> = Vec::new();
    for spec in exp
        .strategies
        .iter()
        .filter(|s| s.runs_on(&p.file) && !s.spp.is_empty())
    {
        let mut row = Vec::new();
        for &spp in &exp.spp {
            let found = rows.iter().find(|r| {
                r.scene == p.scene.name
                    && r.strategy == spec.label
                    && r.seed == seed
                    && r.budget == BUDGET_SPP
                    && r.budget_value == spp as f64
            });
            row.push(match found {
                Some(r) => read_exr(&dir.join(&r.image))?,
                None => blank.clone(),
            });
        }
        images.push(row);
    }
    if images.is_empty() {
        return Ok(());
    }
    images.push(vec![p.reference.image.clone()]);
    let grid_rows: Vec<Vec<&crate::film::Image>> = images.iter().map(|r| r.iter().collect()).collect();
    let grid = crate::film::image_grid(&grid_rows, 2);
    write_png(
        &grid,
        &dir.join(crate::report::html::progression_path(&p.scene.name)),
        exp.exposure,
    )
}
