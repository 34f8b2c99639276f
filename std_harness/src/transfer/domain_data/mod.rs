//! What the transfer experiments know of a domain beyond its tasks ([`DomainData`]): the
//! published source datasets and their file layout, how fresh source data are generated,
//! and the GPs IWFQI weighs records with. A [`Domain`](crate::domains::Domain) is the tasks
//! only; each domain's data live here, one module each.
//!
//! - [`puddle`]: Puddle World (spec §6, §7.6);
//! - [`dam`]: the IWFQI paper's water reservoir;
//! - [`acrobot`]: the IWFQI paper's multitask Acrobot;
//! - [`unit_box`]: the plant suite's plants on the unit box (generated sources only).

pub mod acrobot;
pub mod dam;
pub mod puddle;
pub mod unit_box;

use std::io::Read;

use super::gp::Weighting;
use super::sources::{Generation, SourceLayout, SourceSet};

/// A domain's source data and weighting (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct DomainData<const D: usize> {
    /// The IWFQI weighting of the published runs.
    pub weighting: Weighting<D>,
    /// The CSV layout of the domain's source files.
    pub layout: SourceLayout,
    /// The published source datasets (embedded).
    pub published: fn() -> anyhow::Result<SourceSet<D>>,
    /// How fresh source data are generated (`--sources generate`).
    pub generation: Generation,
}

/// Decompresses embedded gzip files.
fn gunzip(files: &[&[u8]]) -> anyhow::Result<Vec<String>> {
    files
        .iter()
        .map(|bytes| {
            let mut text = String::new();
            flate2::read::GzDecoder::new(*bytes).read_to_string(&mut text)?;
            Ok(text)
        })
        .collect()
}
