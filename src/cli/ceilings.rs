//! `voxscope ceilings` on the command line: what the GPU itself can do (memory bandwidth,
//! filtered samples, fetch latencies, FMA rate, store-only invocations), measured by the bench
//! crate ([`voxscope_bench::ceilings`]), as a table or one JSON object.

use clap::Args;

use voxscope_render::CeilingSizes;

#[derive(Debug, Args)]
pub struct CeilingsArgs {
    /// A few thousandth of the work: for software devices and tests.
    #[arg(long)]
    pub quick: bool,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &CeilingsArgs) -> Result<(), String> {
    let sizes = if args.quick {
        CeilingSizes::QUICK
    } else {
        CeilingSizes::FULL
    };
    let report = voxscope_bench::ceilings::measure(sizes).map_err(|e| e.to_string())?;
    if args.json {
        outln!("{}", report.json());
    } else {
        out!("{}", report.table());
    }
    Ok(())
}
