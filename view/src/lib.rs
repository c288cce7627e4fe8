//! The live view: a browser page of every signal while `acq record` (or the
//! demo) records, and the same page over any recorded session (`acq view`).
//!
//! - [`series`]: a signal as min/max buckets, folded per pixel column.
//! - [`model`]: what the page shows of one session.
//! - [`frames`]: the raw frames per bus and CAN id, beside the signals.
//! - [`live`]: the recorder's observer; a thread decodes and finds holds.
//! - [`recorded`]: a session read from disk, with `acq extract`'s holds.
//! - [`index`]: a recorded session's view kept beside it for the next open.
//! - [`layout`]: which signals go in which plot, as a file (`--layout`).
//! - [`server`]: the HTTP server (read-only, loopback or token, CSP, events).
//! - [`host`]: the `--view` options and the page on a runtime of its own.
//! - [`page`]: the page's HTML skeleton, script, style and vendored uPlot.
//! - [`study_worker`]: a study fed the holds as they close, shown as `study`.
//!
//! The view sits after analysis in the data flow: it reads frames, samples
//! and measured values, and nothing it does reaches back into the recorder
//! except the counting of frames it could not show.

pub mod frames;
#[cfg(feature = "server")]
pub mod host;
pub mod index;
pub mod layout;
pub mod live;
pub mod model;
pub mod page;
pub mod recorded;
pub mod series;
#[cfg(feature = "server")]
pub mod server;
pub mod study_worker;

#[cfg(feature = "server")]
pub use host::{ViewHost, ViewOptions};
pub use live::{live_session, LiveFeed, SharedSession};
pub use recorded::{open_session, Source};
#[cfg(feature = "server")]
pub use server::{access_for, parse_address, serve, Access, Pages, ViewServer};
pub use study_worker::{HoldsStudy, SharedStudy, StudyWorker};

/// Where the page is served when `--view` is given without an address.
pub const DEFAULT_ADDRESS: &str = "127.0.0.1:8750";
