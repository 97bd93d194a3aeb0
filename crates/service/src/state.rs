//! The service's state: the store (one SQLite connection: SQLite has one
//! writer at a time anyway) and each person's live advisor, behind one
//! mutex. Every request's store work runs on tokio's blocking pool.

use crate::auth::{self, Caller, Need};
use crate::error::ApiError;
use abba_store::{Live, Store, StoreError};
use axum::http::{header, HeaderMap};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The store and the live advisors.
pub struct Core {
    /// The store (opened with `synchronous=FULL`).
    pub store: Store,
    live: HashMap<i64, Live>,
    /// SQLite's `data_version` when last looked at: it changes when
    /// another connection (the CLI, another process) commits.
    data_version: Option<i64>,
}

impl Core {
    /// Wraps an open store.
    pub fn new(store: Store) -> Self {
        Self {
            store,
            live: HashMap::new(),
            data_version: None,
        }
    }

    /// Drops every live advisor when another connection wrote to the file
    /// since the last look (`abba answer` or `abba import` while the
    /// service runs): they are rebuilt from the store on next use.
    pub fn notice_other_writers(&mut self) -> Result<(), StoreError> {
        let v: i64 = self
            .store
            .connection()
            .pragma_query_value(None, "data_version", |r| r.get(0))?;
        if self.data_version.is_some_and(|old| old != v) {
            self.live.clear();
        }
        self.data_version = Some(v);
        Ok(())
    }

    /// The person's live state, built from the store on first use.
    pub fn live(&mut self, id: i64) -> Result<&mut Live, StoreError> {
        if !self.live.contains_key(&id) {
            let l = self.store.live(id)?;
            self.live.insert(id, l);
        }
        self.live
            .get_mut(&id)
            .ok_or_else(|| StoreError::corrupt("live state", "missing after insert"))
    }

    /// Runs `f` with the person's live state and the store; on an error the
    /// live state is dropped (the next request rebuilds it from the store).
    pub fn with_live<T>(
        &mut self,
        id: i64,
        f: impl FnOnce(&mut Store, &mut Live) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        let mut live = match self.live.remove(&id) {
            Some(l) => l,
            None => self.store.live(id)?,
        };
        let out = f(&mut self.store, &mut live);
        if out.is_ok() {
            self.live.insert(id, live);
        }
        out
    }

    /// Replaces a person's live state.
    pub fn set_live(&mut self, id: i64, live: Live) {
        self.live.insert(id, live);
    }
}

/// Shared by every handler.
#[derive(Clone)]
pub struct AppState {
    core: Arc<Mutex<Core>>,
}

impl AppState {
    /// The state over an open store.
    pub fn new(store: Store) -> Self {
        Self {
            core: Arc::new(Mutex::new(Core::new(store))),
        }
    }

    /// Checks the request's token against what the endpoint needs.
    pub async fn authorize(&self, headers: &HeaderMap, need: Need) -> Result<Caller, ApiError> {
        let auth = headers
            .get(header::AUTHORIZATION)
            .map(|v| v.to_str().map(str::to_string).unwrap_or_default());
        self.core(move |core| auth::authorize(&core.store, auth.as_deref(), need))
            .await
    }

    /// Runs `f` on the blocking pool with the core locked.
    pub async fn core<T: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Core) -> Result<T, ApiError> + Send + 'static,
    ) -> Result<T, ApiError> {
        let core = Arc::clone(&self.core);
        tokio::task::spawn_blocking(move || {
            // A panic while the lock was held leaves the store consistent
            // (transactions roll back) but perhaps not a live advisor: drop
            // them all (they are rebuilt from the store) and carry on.
            let mut guard = match core.lock() {
                Ok(c) => c,
                Err(poisoned) => {
                    let mut c = poisoned.into_inner();
                    c.live.clear();
                    core.clear_poison();
                    c
                }
            };
            guard.notice_other_writers()?;
            f(&mut guard)
        })
        .await
        .map_err(ApiError::internal)?
    }
}
