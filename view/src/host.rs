//! The page on a runtime of its own, so that serving never takes a worker
//! from the recorder, and the `--view` options every command shares.

use std::net::SocketAddr;

use acq_io::error::{AcqError, Result};

use crate::server::{access_for, parse_address, serve, Access, Pages, ViewServer};
use crate::DEFAULT_ADDRESS;

/// `--view [HOST:PORT]` and `--view-remote`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ViewArgs {
    /// Serve a page of every signal, live, at HOST:PORT (127.0.0.1:8750, on
    /// this machine only, when no address is given). Open the URL printed.
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1, default_missing_value = DEFAULT_ADDRESS)]
    pub view: Option<String>,
    /// Let --view serve an address other machines can reach. Every request
    /// then needs the random token in the URL printed at start.
    #[arg(long, requires = "view")]
    pub view_remote: bool,
}

impl ViewArgs {
    /// The address and who may use it; checked before anything starts.
    pub fn resolve(&self) -> Result<Option<(SocketAddr, Access)>> {
        let Some(text) = &self.view else {
            return Ok(None);
        };
        let addr = parse_address(text)?;
        Ok(Some((addr, access_for(addr, self.view_remote)?)))
    }
}

/// A running page with the runtime it runs on.
pub struct ViewHost {
    runtime: tokio::runtime::Runtime,
    server: Option<ViewServer>,
}

impl ViewHost {
    /// Binds and serves `sessions`; fails at once if the address is taken.
    pub fn start(addr: SocketAddr, access: Access, pages: impl Into<Pages>) -> Result<Self> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("acq-view-http")
            .enable_all()
            .build()
            .map_err(|e| AcqError::io("starting the view's runtime", e))?;
        let server = runtime.block_on(serve(addr, access, pages))?;
        Ok(ViewHost {
            runtime,
            server: Some(server),
        })
    }

    pub fn url(&self) -> &str {
        self.server.as_ref().map_or("", |s| s.url())
    }

    /// Serves until SIGINT or SIGTERM, then stops.
    pub fn serve_until_interrupted(mut self) {
        let server = self.server.take();
        self.runtime.block_on(async move {
            use tokio::signal::unix::{signal, SignalKind};
            if let (Ok(mut interrupt), Ok(mut terminate)) = (
                signal(SignalKind::interrupt()),
                signal(SignalKind::terminate()),
            ) {
                tokio::select! {
                    _ = interrupt.recv() => {}
                    _ = terminate.recv() => {}
                }
            } else {
                let _ = tokio::signal::ctrl_c().await;
            }
            if let Some(server) = server {
                server.stop().await;
            }
        });
    }

    /// Stops serving now: open pages see the end of the stream.
    pub fn stop(mut self) {
        if let Some(server) = self.server.take() {
            self.runtime.block_on(server.stop());
        }
    }
}
