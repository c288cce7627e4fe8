//! Where a model run happens: the seam between a study and the machine
//! that runs the user's solver.
//!
//! - [`executor`]: one prepared command run in its directory, as a child
//!   process of acq ([`executor::LocalExecutor`], several at once).
//! - [`slurm`]: the same command as a Slurm batch job, whose id is in its
//!   run directory before acq waits on it, so a resumed study re-attaches
//!   instead of starting it twice.
//! - [`interrupt`]: what to do before acq stops on Ctrl-C (Slurm cancels
//!   its jobs); the program that takes the signal runs the hooks.
//!
//! Knows nothing of studies, twins or CAN: a job is an argv, a directory
//! and a time limit.

pub mod executor;
pub mod interrupt;
pub mod slurm;
