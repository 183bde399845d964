//! `volasso accuracy [--quick] [--cases ...] [--seeds ...] [--methods ...] [--hands ...]
//! [--json] [--export DIR]`: the accuracy harness ([`crate::accuracy`]) on the command line.
//! Prints a table row per case, seed, hand and method as it goes (or one JSON object per line
//! with `--json`), then the mean macro Dice per method over tuning and check cases, clean and
//! leaky lassos side by side. `--export DIR` also writes each case's lassos, the paper's
//! features of every voxel and each method's result as `.npy` files, for
//! `scripts/accuracy_sklearn.py` and for looking into a case (a confusion matrix is
//! `numpy.add.at` over truth and predicted).

use super::CliError;
use crate::accuracy::{self, Case, Hand, Method, PhantomKind, UserModel, report};
use crate::features::{FeatureSet, features_of_voxels};
use crate::phantom::Phantom;
use crate::strokes::TrainingSet;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct AccuracyArgs {
    /// Small phantoms (the CI regression size).
    #[arg(long)]
    pub quick: bool,
    /// Phantoms: foot16, vessels8, brain16, shells8, torso16, head8 (default: all).
    #[arg(long, value_delimiter = ',')]
    pub cases: Vec<String>,
    /// Seeds of phantom noise (and the new phantoms' geometry) and lassos. Seeds 1-4 are the
    /// tuning cases, 5 and above the check cases that decide defaults.
    #[arg(long, value_delimiter = ',', default_values_t = [1u64, 2, 3, 4, 5, 6, 7, 8])]
    pub seeds: Vec<u64>,
    /// Methods (default: all): snsvm-paper5, svm-paper5, forest-paper5, svm-multiscale,
    /// snsvm-multiscale, forest-multiscale, forest-fine, default,
    /// default-voxelwise, default-fine.
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// How the simulated user draws: clean (inside each structure), leaky (loops around it,
    /// two pixels over its border) (default: both).
    #[arg(long, value_delimiter = ',')]
    pub hands: Vec<String>,
    /// Voxels per class the simulated lassos aim for.
    #[arg(long, default_value_t = 130, value_name = "N")]
    pub budget: usize,
    /// Leave the air (truth class 0) unlassoed: it must come out as background.
    #[arg(long)]
    pub no_air_lasso: bool,
    /// One JSON object per line instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Write each case's lassos, truth and paper features as .npy files into DIR.
    #[arg(long, value_name = "DIR")]
    pub export: Option<PathBuf>,
}

fn parse_list<T>(names: &[String], all: &[T], find: impl Fn(&str) -> Option<T>, what: &str) -> Result<Vec<T>, CliError>
where
    T: Copy,
{
    if names.is_empty() {
        return Ok(all.to_vec());
    }
    names.iter().map(|name| find(name).ok_or_else(|| CliError::Usage(format!("unknown {what} '{name}'")))).collect()
}

pub fn run(args: &AccuracyArgs) -> Result<(), CliError> {
    let kinds = parse_list(&args.cases, &PhantomKind::ALL, PhantomKind::from_name, "case")?;
    let methods = parse_list(&args.methods, &Method::ALL, Method::from_name, "method")?;
    let hands = parse_list(&args.hands, &Hand::ALL, Hand::from_name, "hand")?;
    let cases: Vec<Case> =
        kinds.iter().flat_map(|&kind| args.seeds.iter().map(move |&seed| Case { kind, seed })).collect();
    let user =
        UserModel { voxel_budget_per_class: args.budget, lasso_background: !args.no_air_lasso, ..UserModel::default() };
    if !args.json {
        println!("{}", report::header());
    }
    // The first export error stops further exports and is returned at the end.
    let export_error = std::cell::RefCell::new(None);
    let case_folder = |case: &Case, hand: Hand| {
        let export_error = export_error.borrow();
        let folder = args.export.as_ref().filter(|_| export_error.is_none())?;
        Some(folder.join(format!("{}-{}-{}", case.kind.name(), case.seed, hand.name())))
    };
    let outcomes = accuracy::evaluate(
        &cases,
        &methods,
        &hands,
        &user,
        args.quick,
        |case, hand, phantom, training| {
            if let Some(folder) = case_folder(case, hand) {
                *export_error.borrow_mut() = export(&folder, phantom, training, &user).err();
            }
        },
        |outcome, predicted| {
            if args.json {
                println!("{}", report::json(outcome));
            } else {
                println!("{}", report::row(outcome));
            }
            if let Some(folder) = case_folder(&outcome.case, outcome.hand) {
                let name = format!("predicted-{}.npy", outcome.method.name());
                *export_error.borrow_mut() = super::npy::write(&folder.join(&name), &[predicted.len()], predicted)
                    .map_err(|source| CliError::Output { source, path: folder.join(&name) })
                    .err();
            }
        },
    )?;
    if let Some(error) = export_error.into_inner() {
        return Err(error);
    }
    if !args.json {
        println!();
        print!("{}", report::summary(&outcomes, &methods, &hands));
    }
    Ok(())
}

/// Writes `train_features.npy` (paper features of the lassoed voxels), `train_labels.npy`
/// (their class ids), `features.npy` (paper features of every voxel), `truth.npy` (the truth
/// class of every voxel) and `case.json` (class names, how labels map to truth, Otsu's
/// threshold) into `folder`. Each method's result follows as `predicted-METHOD.npy` (the
/// truth class it gives every voxel, in `truth.npy`'s order).
fn export(folder: &Path, phantom: &Phantom, training: &TrainingSet, user: &UserModel) -> Result<(), CliError> {
    let output = |source: std::io::Error, name: &str| CliError::Output { source, path: folder.join(name) };
    std::fs::create_dir_all(folder).map_err(|e| output(e, ""))?;
    let volume = &phantom.volume;
    let features = |voxels: &[usize]| {
        features_of_voxels(volume, FeatureSet::Paper5, voxels).map_err(crate::segmentation::SegmentationError::from)
    };
    let (voxels, labels) = training.labelled_voxels();
    let dim = FeatureSet::Paper5.dim();
    super::npy::write(&folder.join("train_features.npy"), &[voxels.len(), dim], &features(&voxels)?)
        .map_err(|e| output(e, "train_features.npy"))?;
    super::npy::write(&folder.join("train_labels.npy"), &[labels.len()], &labels)
        .map_err(|e| output(e, "train_labels.npy"))?;
    let every: Vec<usize> = (0..volume.voxel_count()).collect();
    super::npy::write(&folder.join("features.npy"), &[every.len(), dim], &features(&every)?)
        .map_err(|e| output(e, "features.npy"))?;
    super::npy::write(&folder.join("truth.npy"), &[phantom.truth.len()], &phantom.truth)
        .map_err(|e| output(e, "truth.npy"))?;
    let case = serde_json::json!({
        "class_names": phantom.class_names,
        "lasso_background": user.lasso_background,
        "otsu_threshold": volume.otsu_threshold(),
        "dims": volume.dims,
    });
    crate::atomic_file::write_atomically(&folder.join("case.json"), |file| {
        std::io::Write::write_all(file, case.to_string().as_bytes())
    })
    .map_err(|e| output(e, "case.json"))
}
