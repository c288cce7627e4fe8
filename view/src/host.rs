//! The page on a runtime of its own, so that serving never takes a worker
//! from the recorder, and where it is served.

use std::net::SocketAddr;

use acq_error::{AcqError, Result};

use crate::server::{access_for, parse_address, serve, Access, Pages, ViewServer};

/// Where the page is served, if at all (`--view [HOST:PORT]` and
/// `--view-remote` on the command line).
#[derive(Clone, Debug, Default)]
pub struct ViewOptions {
    /// The page's address ([`crate::DEFAULT_ADDRESS`], this machine only, unless
    /// told); `None` serves no page.
    pub address: Option<String>,
    /// Whether an address other machines can reach is allowed: every
    /// request then needs the random token in the URL printed at start.
    pub remote: bool,
}

impl ViewOptions {
    /// The address and who may use it; checked before anything starts.
    pub fn resolve(&self) -> Result<Option<(SocketAddr, Access)>> {
        let Some(text) = &self.address else {
            return Ok(None);
        };
        let addr = parse_address(text)?;
        Ok(Some((addr, access_for(addr, self.remote)?)))
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

    /// Serves until `stop` resolves, then stops.
    pub fn serve_until(mut self, stop: impl std::future::Future<Output = ()>) {
        let server = self.server.take();
        self.runtime.block_on(async move {
            stop.await;
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
