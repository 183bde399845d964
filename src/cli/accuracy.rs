//! `volasso accuracy [--quick] [--cases ...] [--seeds ...] [--methods ...] [--json]`: the
//! accuracy harness ([`crate::accuracy`]) on the command line. Prints a table row
//! per case, seed and method as it goes (or one JSON object per line with `--json`), then the
//! mean macro Dice per method over tuning and check cases.

use super::CliError;
use crate::accuracy::{self, Case, Method, PhantomKind, UserModel, report};
use clap::Args;

#[derive(Debug, Args)]
pub struct AccuracyArgs {
    /// Small phantoms (the CI regression size).
    #[arg(long)]
    pub quick: bool,
    /// Phantoms: foot16, vessels8, brain16, shells8 (default: all).
    #[arg(long, value_delimiter = ',')]
    pub cases: Vec<String>,
    /// Seeds of phantom noise and lassos (default: 1-6; seeds 1-4 of foot16 and vessels8 are
    /// the tuning cases, everything else is held out).
    #[arg(long, value_delimiter = ',', default_values_t = [1u64, 2, 3, 4, 5, 6])]
    pub seeds: Vec<u64>,
    /// Methods (default: all): snsvm-paper5, svm-paper5, forest-paper5, svm-multiscale,
    /// snsvm-multiscale, forest-multiscale, forest-fine, default.
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// Voxels per class the simulated lassos aim for.
    #[arg(long, default_value_t = 130, value_name = "N")]
    pub budget: usize,
    /// Let the lassos cross the true border by this many pixels (sloppy user).
    #[arg(long, default_value_t = 0, value_name = "PIXELS")]
    pub sloppy: u32,
    /// One JSON object per line instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &AccuracyArgs) -> Result<(), CliError> {
    let kinds: Vec<PhantomKind> = if args.cases.is_empty() {
        PhantomKind::ALL.to_vec()
    } else {
        args.cases
            .iter()
            .map(|name| PhantomKind::from_name(name).ok_or_else(|| CliError::Usage(format!("unknown case '{name}'"))))
            .collect::<Result<_, _>>()?
    };
    let methods: Vec<Method> = if args.methods.is_empty() {
        Method::ALL.to_vec()
    } else {
        args.methods
            .iter()
            .map(|name| Method::from_name(name).ok_or_else(|| CliError::Usage(format!("unknown method '{name}'"))))
            .collect::<Result<_, _>>()?
    };
    let cases: Vec<Case> =
        kinds.iter().flat_map(|&kind| args.seeds.iter().map(move |&seed| Case { kind, seed })).collect();
    let user = UserModel { voxel_budget_per_class: args.budget, sloppy_pixels: args.sloppy, ..UserModel::default() };
    if !args.json {
        println!("{}", report::header());
    }
    let outcomes = accuracy::evaluate(&cases, &methods, &user, args.quick, |outcome| {
        if args.json {
            println!("{}", report::json(outcome));
        } else {
            println!("{}", report::row(outcome));
        }
    })?;
    if !args.json {
        println!();
        print!("{}", report::summary(&outcomes, &methods));
    }
    Ok(())
}
