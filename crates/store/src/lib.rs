//! abba-store: a person's durable store, and the advisor as a function of
//! that store.
//!
//! One database holds many persons. Per person: the settings (zone, mode, meal
//! windows, starting therapy, clinician bounds, the advisor's
//! configuration), the append-only log of device records (each with its
//! source and its identity there), the imports, every suggestion with its
//! full explanation, the person's answers, and an advisor snapshot. The
//! advisor's state is a cache: it is rebuilt from the records and answers
//! whenever the snapshot does not match them (decisions are a pure
//! function of events, starting therapy and configuration).
//!
//! Each import and each answer is one transaction. The logic speaks to the
//! database only through [`backend`]: named statements with neutral values
//! in a [`backend::Tx`]; every SQL string, the schema's DDL and the
//! database's errors live in the backend's module (SQLite, one file in WAL
//! mode, is the embedded default).
//! abba-store depends on abba-core, abba-advisor and abba-io, never on the
//! simulator. abba is research software, not a medical device.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod advise;
pub mod answer;
pub mod app;
pub mod autotune;
pub mod backend;
pub mod busy;
pub mod check;
pub mod copy;
pub mod day_1;
pub mod edited;
pub mod effect;
pub mod error;
pub mod history;
pub mod import;
pub mod in_force;
pub mod link;
pub mod live;
pub mod log;
pub mod one_source;
pub mod other_unit;
pub mod person;
pub mod replay;
pub mod report;
pub mod schema;
pub mod session;
pub mod store;
pub mod submission;
pub mod testing;
pub mod token;

pub use advise::{Advice, NOTICE};
pub use answer::{AnswerKind, Answers};
pub use error::StoreError;
pub use import::ImportSummary;
pub use live::{Live, Posted, Produced, SuggestionAnswer};
pub use person::{NewPerson, Person};
pub use store::{AnswerRequest, ProfileResolution, Store};
