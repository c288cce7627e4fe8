//! `acq demo`: the whole chain on the shipped sessions.

use std::path::PathBuf;

use acq_demo::DemoOptions;
use acq_error::Result;
use clap::Args;

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Report directory (a previous demo's output there is replaced).
    #[arg(long, value_name = "DIR", default_value = DemoOptions::DEFAULT_OUT)]
    pub out: PathBuf,
    /// Replay on these SocketCAN interfaces (e.g. vcan0 vcan1: one per bus of
    /// the excavator rig) instead of the in-process bus; sessions then play
    /// one after another.
    #[arg(long = "iface", value_name = "IFACE")]
    pub interfaces: Vec<String>,
    /// Analyse the sessions already recorded in DIR (named as the shipped
    /// ones, e.g. by an earlier `--acquire-only`) instead of replaying.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["interfaces", "acquire_only"])]
    pub sessions: Option<PathBuf>,
    /// Stop once the sessions are recorded (analyse them later with --sessions).
    #[arg(long)]
    pub acquire_only: bool,
    /// Where fixtures/ and data/ are [default: the current directory when it
    /// has them, else the source tree acq was built from].
    #[arg(long, value_name = "DIR")]
    pub data: Option<PathBuf>,
    /// The live page of the sessions as they are replayed; it stays up after
    /// the demo until Ctrl-C.
    #[command(flatten)]
    pub view: super::view::ViewArgs,
}

pub fn run_demo(args: DemoArgs) -> Result<()> {
    acq_demo::run(
        DemoOptions {
            out: args.out,
            interfaces: args.interfaces,
            sessions: args.sessions,
            acquire_only: args.acquire_only,
            data: args.data,
            view: args.view.options(),
        },
        || Box::pin(super::interrupt::interrupted()),
    )
}
