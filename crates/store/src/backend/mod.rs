//! The seam between the store's logic and a database.
//!
//! Everything above this module (persons, imports, replay, advice, the
//! service's live advisors) speaks to a database only through [`Db`]: run
//! a *named* statement ([`Q`]) with backend-neutral [`Value`]s, get
//! [`Row`]s back. The SQL text of every statement, the schema of every
//! migration step and the mapping of the database's errors onto
//! [`StoreError`] live in one module per backend ([`sqlite`], the embedded
//! default, and [`postgres`], a server shared by replicas). A
//! backend's connection is a [`Conn`]; a transaction is a [`Tx`], which
//! rolls back when dropped without [`Tx::commit`].
//!
//! Why statements by name rather than one trait method per operation: the
//! row mapping (JSON documents, instants, enums) is the same for every
//! backend and stays with the logic that owns it, while a backend only
//! says how its dialect spells each statement.

pub mod postgres;
pub mod sqlite;

use crate::error::StoreError;

pub use sqlite::sql::Q;

/// A value bound to a statement's parameter or read from a row.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// SQL NULL.
    Null,
    /// A 64-bit integer (booleans are 0 and 1).
    Int(i64),
    /// A double.
    Real(f64),
    /// UTF-8 text.
    Text(String),
    /// Bytes.
    Blob(Vec<u8>),
}

impl From<i64> for Value {
    fn from(v: i64) -> Self {
        Value::Int(v)
    }
}
impl From<&i64> for Value {
    fn from(v: &i64) -> Self {
        Value::Int(*v)
    }
}
impl From<bool> for Value {
    fn from(v: bool) -> Self {
        Value::Int(i64::from(v))
    }
}
impl From<f64> for Value {
    fn from(v: f64) -> Self {
        Value::Real(v)
    }
}
impl From<&f64> for Value {
    fn from(v: &f64) -> Self {
        Value::Real(*v)
    }
}
impl From<&str> for Value {
    fn from(v: &str) -> Self {
        Value::Text(v.to_string())
    }
}
impl From<String> for Value {
    fn from(v: String) -> Self {
        Value::Text(v)
    }
}
impl From<&String> for Value {
    fn from(v: &String) -> Self {
        Value::Text(v.clone())
    }
}
impl From<&[u8]> for Value {
    fn from(v: &[u8]) -> Self {
        Value::Blob(v.to_vec())
    }
}
impl<T: Into<Value>> From<Option<T>> for Value {
    fn from(v: Option<T>) -> Self {
        v.map_or(Value::Null, Into::into)
    }
}

/// The parameters of a statement: `args![a, b]` is `&[Value::from(a),
/// Value::from(b)]`.
macro_rules! args {
    ($($v:expr),* $(,)?) => {
        &[$($crate::backend::Value::from($v)),*][..]
    };
}
pub(crate) use args;

/// One row of a result, its columns in the statement's order.
#[derive(Debug, Clone, PartialEq)]
pub struct Row(pub Vec<Value>);

fn column_error(i: usize, want: &str, got: &Value) -> StoreError {
    StoreError::corrupt("row", format!("column {i}: expected {want}, found {got:?}"))
}

impl Row {
    fn at(&self, i: usize) -> Result<&Value, StoreError> {
        self.0
            .get(i)
            .ok_or_else(|| StoreError::corrupt("row", format!("no column {i}")))
    }

    /// An integer column.
    pub fn int(&self, i: usize) -> Result<i64, StoreError> {
        match self.at(i)? {
            Value::Int(v) => Ok(*v),
            v => Err(column_error(i, "an integer", v)),
        }
    }

    /// An integer column that may be NULL.
    pub fn opt_int(&self, i: usize) -> Result<Option<i64>, StoreError> {
        match self.at(i)? {
            Value::Null => Ok(None),
            _ => self.int(i).map(Some),
        }
    }

    /// A boolean stored as an integer (or a boolean expression).
    pub fn bool(&self, i: usize) -> Result<bool, StoreError> {
        Ok(self.int(i)? != 0)
    }

    /// A real column (an integer is widened, as SQLite may store one).
    pub fn real(&self, i: usize) -> Result<f64, StoreError> {
        match self.at(i)? {
            Value::Real(v) => Ok(*v),
            Value::Int(v) => Ok(*v as f64),
            v => Err(column_error(i, "a number", v)),
        }
    }

    /// A text column.
    pub fn text(&self, i: usize) -> Result<String, StoreError> {
        match self.at(i)? {
            Value::Text(v) => Ok(v.clone()),
            v => Err(column_error(i, "text", v)),
        }
    }

    /// A text column, borrowed.
    pub fn str(&self, i: usize) -> Result<&str, StoreError> {
        match self.at(i)? {
            Value::Text(v) => Ok(v),
            v => Err(column_error(i, "text", v)),
        }
    }

    /// A text column that may be NULL.
    pub fn opt_text(&self, i: usize) -> Result<Option<String>, StoreError> {
        match self.at(i)? {
            Value::Null => Ok(None),
            _ => self.text(i).map(Some),
        }
    }

    /// A bytes column.
    pub fn blob(&self, i: usize) -> Result<Vec<u8>, StoreError> {
        match self.at(i)? {
            Value::Blob(v) => Ok(v.clone()),
            v => Err(column_error(i, "bytes", v)),
        }
    }
}

/// What a database error was, as far as the callers care.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DbErrorKind {
    /// Another connection held a lock longer than the wait allowed.
    Busy,
    /// The database cannot be written (a read-only file, folder or medium).
    ReadOnly,
    /// A constraint refused the write (a key already held...).
    Constraint,
    /// The database could not be reached or opened.
    Connect,
    /// Anything else.
    Other,
}

/// A database error, the same type whatever the backend.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DbError {
    /// Which backend said it.
    pub backend: &'static str,
    /// What kind of error.
    pub kind: DbErrorKind,
    /// The database's own message.
    pub message: String,
}

impl std::fmt::Display for DbError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for DbError {}

/// A store location as it may be shown: a PostgreSQL URL without its
/// password (`postgres://u:***@host/db`, `password=***`), a file as it is.
pub fn shown(db: &std::path::Path) -> String {
    let s = db.display().to_string();
    if !postgres::is_url(&s) {
        return s;
    }
    let mut out = s.clone();
    if let Some(start) = s.find("://").map(|i| i + 3) {
        let end = s[start..].find(['/', '?']).map_or(s.len(), |i| start + i);
        if let Some(at) = s[start..end].rfind('@') {
            if let Some(colon) = s[start..start + at].find(':') {
                out = format!("{}***{}", &s[..start + colon + 1], &s[start + at..]);
            }
        }
    }
    if let Some(i) = out.find("password=") {
        let end = out[i..].find('&').map_or(out.len(), |j| i + j);
        out.replace_range(i + 9..end, "***");
    }
    out
}

/// What [`Db::each_row`] hands each row to.
pub type RowSink<'f> = dyn FnMut(Row) -> Result<(), StoreError> + 'f;

/// A connection or a transaction: runs named statements.
pub trait Db {
    /// Runs a statement that returns no rows; the number of rows changed.
    fn execute(&self, q: Q, params: &[Value]) -> Result<usize, StoreError>;

    /// Runs a query; every row.
    fn rows(&self, q: Q, params: &[Value]) -> Result<Vec<Row>, StoreError>;

    /// Runs an insert of one row with a generated `id`; that id.
    fn insert_id(&self, q: Q, params: &[Value]) -> Result<i64, StoreError>;

    /// Runs a query and hands each row to `f` in turn, never holding every
    /// row at once (SQLite steps its statement; PostgreSQL's connection
    /// thread passes rows on in parts): a person's whole log is read this
    /// way. `f` must not run statements on this connection (on PostgreSQL
    /// its thread is busy with this query: that would wait forever).
    fn each_row(&self, q: Q, params: &[Value], f: &mut RowSink<'_>) -> Result<(), StoreError> {
        self.rows(q, params)?.into_iter().try_for_each(f)
    }

    /// The first row, if any.
    fn row(&self, q: Q, params: &[Value]) -> Result<Option<Row>, StoreError> {
        Ok(self.rows(q, params)?.into_iter().next())
    }

    /// The one row a query always returns (an aggregate).
    fn one(&self, q: Q, params: &[Value]) -> Result<Row, StoreError> {
        self.row(q, params)?
            .ok_or_else(|| StoreError::corrupt("query", format!("{q:?} returned no row")))
    }
}

/// A connection to one store.
pub enum Conn {
    /// An SQLite file.
    Sqlite(sqlite::Sqlite),
    /// A PostgreSQL database (boxed: its client is the larger).
    Postgres(Box<postgres::Pg>),
}

/// A transaction of a [`Conn`]; dropped without [`Tx::commit`], it rolls
/// back.
pub enum Tx<'a> {
    /// SQLite's.
    Sqlite(sqlite::SqliteTx<'a>),
    /// PostgreSQL's.
    Postgres(postgres::PgTx<'a>),
}

impl Conn {
    /// Begins a transaction that may write (SQLite: IMMEDIATE, the write
    /// lock taken at once).
    pub fn transaction(&mut self) -> Result<Tx<'_>, StoreError> {
        match self {
            Conn::Sqlite(c) => Ok(Tx::Sqlite(c.transaction(true)?)),
            Conn::Postgres(c) => Ok(Tx::Postgres(c.transaction(true)?)),
        }
    }

    /// Begins a transaction that may write, but only person `person`'s
    /// data (their events, answers, settings): SQLite as
    /// [`Conn::transaction`]; PostgreSQL lets writes for other persons
    /// run beside it ([`postgres::Pg::transaction_for`]).
    pub fn transaction_for(&mut self, person: i64) -> Result<Tx<'_>, StoreError> {
        match self {
            Conn::Sqlite(c) => Ok(Tx::Sqlite(c.transaction(true)?)),
            Conn::Postgres(c) => Ok(Tx::Postgres(c.transaction_for(person)?)),
        }
    }

    /// Begins a transaction that only reads (no write lock taken).
    pub fn read_transaction(&mut self) -> Result<Tx<'_>, StoreError> {
        match self {
            Conn::Sqlite(c) => Ok(Tx::Sqlite(c.transaction(false)?)),
            Conn::Postgres(c) => Ok(Tx::Postgres(c.transaction(false)?)),
        }
    }

    /// The database's own consistency check ("ok" when sound; a server
    /// checks its own pages and answers "ok").
    pub fn integrity(&self) -> Result<Vec<String>, StoreError> {
        match self {
            Conn::Sqlite(c) => c.integrity(),
            Conn::Postgres(_) => Ok(vec!["ok".into()]),
        }
    }

    /// True when the database was opened read-only.
    pub fn is_read_only(&self) -> Result<bool, StoreError> {
        match self {
            Conn::Sqlite(c) => c.is_read_only(),
            Conn::Postgres(c) => c.is_read_only(),
        }
    }

    /// SQLite's `synchronous` level (1 NORMAL, 2 FULL); a server whose
    /// commits are durable when they return says 2.
    pub fn synchronous(&self) -> Result<i64, StoreError> {
        match self {
            Conn::Sqlite(c) => c.synchronous(),
            Conn::Postgres(_) => Ok(2),
        }
    }

    /// Takes the store-wide lock `key` for background work when no other
    /// process holds it (PostgreSQL: a session advisory lock, released
    /// when this connection closes; SQLite: always taken, the one file's
    /// writers take turns anyway). False when another holds it.
    pub fn try_lock(&self, key: i64) -> Result<bool, StoreError> {
        match self {
            Conn::Sqlite(_) => Ok(true),
            Conn::Postgres(c) => c.try_lock(key),
        }
    }

    /// Runs a write that may be skipped (a session's last use): at once or
    /// not at all, never waiting for another writer. `Ok(None)` when the
    /// store is busy (SQLite: another connection holds the write lock; a
    /// PostgreSQL row lock held by another transaction).
    pub fn try_execute(&mut self, q: Q, params: &[Value]) -> Result<Option<usize>, StoreError> {
        let out = match self {
            Conn::Sqlite(c) => c.execute_no_wait(q, params),
            Conn::Postgres(c) => c.execute(q, params),
        };
        match out {
            Ok(n) => Ok(Some(n)),
            Err(StoreError::Db(DbError {
                kind: DbErrorKind::Busy,
                ..
            })) => Ok(None),
            Err(e) => Err(e),
        }
    }

    /// The backend's name (`sqlite`, `postgres`).
    pub fn backend(&self) -> &'static str {
        match self {
            Conn::Sqlite(_) => "sqlite",
            Conn::Postgres(_) => "postgres",
        }
    }
}

impl Db for Conn {
    fn execute(&self, q: Q, params: &[Value]) -> Result<usize, StoreError> {
        match self {
            Conn::Sqlite(c) => c.db().execute(q, params),
            Conn::Postgres(c) => c.execute(q, params),
        }
    }
    fn rows(&self, q: Q, params: &[Value]) -> Result<Vec<Row>, StoreError> {
        match self {
            Conn::Sqlite(c) => c.db().rows(q, params),
            Conn::Postgres(c) => c.rows(q, params),
        }
    }
    fn insert_id(&self, q: Q, params: &[Value]) -> Result<i64, StoreError> {
        match self {
            Conn::Sqlite(c) => c.db().insert_id(q, params),
            Conn::Postgres(c) => c.insert_id(q, params),
        }
    }
    fn each_row(&self, q: Q, params: &[Value], f: &mut RowSink<'_>) -> Result<(), StoreError> {
        match self {
            Conn::Sqlite(c) => c.db().each_row(q, params, f),
            Conn::Postgres(c) => c.each_row(q, params, f),
        }
    }
}

impl Tx<'_> {
    /// Commits.
    pub fn commit(self) -> Result<(), StoreError> {
        match self {
            Tx::Sqlite(t) => t.commit(),
            Tx::Postgres(t) => t.commit(),
        }
    }
}

impl Db for Tx<'_> {
    fn execute(&self, q: Q, params: &[Value]) -> Result<usize, StoreError> {
        match self {
            Tx::Sqlite(t) => t.db().execute(q, params),
            Tx::Postgres(t) => t.execute(q, params),
        }
    }
    fn rows(&self, q: Q, params: &[Value]) -> Result<Vec<Row>, StoreError> {
        match self {
            Tx::Sqlite(t) => t.db().rows(q, params),
            Tx::Postgres(t) => t.rows(q, params),
        }
    }
    fn insert_id(&self, q: Q, params: &[Value]) -> Result<i64, StoreError> {
        match self {
            Tx::Sqlite(t) => t.db().insert_id(q, params),
            Tx::Postgres(t) => t.insert_id(q, params),
        }
    }
    fn each_row(&self, q: Q, params: &[Value], f: &mut RowSink<'_>) -> Result<(), StoreError> {
        match self {
            Tx::Sqlite(t) => t.db().each_row(q, params, f),
            Tx::Postgres(t) => t.each_row(q, params, f),
        }
    }
}
