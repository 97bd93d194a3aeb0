//! The SQLite backend: one file, WAL mode, IMMEDIATE write transactions,
//! the statements of [`sql`] prepared once per connection (rusqlite's
//! statement cache), the schema steps of [`schema`].

pub mod schema;
pub mod sql;

use super::{Db, DbError, DbErrorKind, Row, RowSink, Value, Q};
use crate::error::StoreError;
use rusqlite::types::{ToSqlOutput, ValueRef};
use rusqlite::{Connection, ToSql};
use std::path::Path;

/// How hard a commit waits for the disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sync {
    /// `synchronous=NORMAL`: in WAL mode a crash of the process loses
    /// nothing committed, a power loss may lose the last commits (the CLI).
    Normal,
    /// `synchronous=FULL`: every commit is on disk before it returns (the
    /// service, which acknowledges events only after COMMIT).
    Full,
}

/// An SQLite error as the store's [`StoreError::Db`], its message kept.
pub(crate) fn err(e: rusqlite::Error) -> StoreError {
    let kind = match &e {
        rusqlite::Error::SqliteFailure(f, _) => match f.code {
            rusqlite::ErrorCode::DatabaseBusy | rusqlite::ErrorCode::DatabaseLocked => {
                DbErrorKind::Busy
            }
            rusqlite::ErrorCode::ReadOnly => DbErrorKind::ReadOnly,
            rusqlite::ErrorCode::ConstraintViolation => DbErrorKind::Constraint,
            rusqlite::ErrorCode::CannotOpen => DbErrorKind::Connect,
            _ => DbErrorKind::Other,
        },
        _ => DbErrorKind::Other,
    };
    StoreError::Db(DbError {
        backend: "sqlite",
        kind,
        message: e.to_string(),
    })
}

impl ToSql for Value {
    fn to_sql(&self) -> rusqlite::Result<ToSqlOutput<'_>> {
        Ok(match self {
            Value::Null => ToSqlOutput::Borrowed(ValueRef::Null),
            Value::Int(v) => ToSqlOutput::Borrowed(ValueRef::Integer(*v)),
            Value::Real(v) => ToSqlOutput::Borrowed(ValueRef::Real(*v)),
            Value::Text(v) => ToSqlOutput::Borrowed(ValueRef::Text(v.as_bytes())),
            Value::Blob(v) => ToSqlOutput::Borrowed(ValueRef::Blob(v)),
        })
    }
}

fn value(v: ValueRef<'_>) -> Result<Value, StoreError> {
    Ok(match v {
        ValueRef::Null => Value::Null,
        ValueRef::Integer(i) => Value::Int(i),
        ValueRef::Real(r) => Value::Real(r),
        ValueRef::Text(t) => Value::Text(
            std::str::from_utf8(t)
                .map_err(|e| StoreError::corrupt("text column", e))?
                .to_string(),
        ),
        ValueRef::Blob(b) => Value::Blob(b.to_vec()),
    })
}

/// Statements on a connection or a transaction (which derefs to one).
pub struct SqliteDb<'c>(pub &'c Connection);

impl Db for SqliteDb<'_> {
    fn execute(&self, q: Q, params: &[Value]) -> Result<usize, StoreError> {
        let mut st = self.0.prepare_cached(sql::text(q)).map_err(err)?;
        st.execute(rusqlite::params_from_iter(params)).map_err(err)
    }

    fn rows(&self, q: Q, params: &[Value]) -> Result<Vec<Row>, StoreError> {
        let mut out = Vec::new();
        self.each_row(q, params, &mut |row| {
            out.push(row);
            Ok(())
        })?;
        Ok(out)
    }

    fn each_row(&self, q: Q, params: &[Value], f: &mut RowSink<'_>) -> Result<(), StoreError> {
        let mut st = self.0.prepare_cached(sql::text(q)).map_err(err)?;
        let n = st.column_count();
        let mut rows = st.query(rusqlite::params_from_iter(params)).map_err(err)?;
        while let Some(r) = rows.next().map_err(err)? {
            let mut row = Vec::with_capacity(n);
            for i in 0..n {
                row.push(value(r.get_ref(i).map_err(err)?)?);
            }
            f(Row(row))?;
        }
        Ok(())
    }

    fn insert_id(&self, q: Q, params: &[Value]) -> Result<i64, StoreError> {
        self.execute(q, params)?;
        Ok(self.0.last_insert_rowid())
    }
}

/// An open SQLite store.
pub struct Sqlite {
    conn: Connection,
}

/// A transaction of [`Sqlite`].
pub struct SqliteTx<'a>(rusqlite::Transaction<'a>);

impl SqliteTx<'_> {
    /// Its statements.
    pub fn db(&self) -> SqliteDb<'_> {
        SqliteDb(&self.0)
    }

    /// Commits.
    pub fn commit(self) -> Result<(), StoreError> {
        self.0.commit().map_err(err)
    }
}

impl Sqlite {
    /// Opens (creating if needed) a store file: WAL journal, foreign keys
    /// on, every write transaction IMMEDIATE, migrations applied.
    ///
    /// Every transaction that may write begins IMMEDIATE: it takes the
    /// write lock at BEGIN (waiting up to `busy`), so a transaction that
    /// reads and then writes is never refused half-way ("database is
    /// locked" when a deferred read transaction is upgraded while another
    /// connection writes, which no busy timeout can wait out).
    pub fn open(path: &Path, sync: Sync, busy: std::time::Duration) -> Result<Self, StoreError> {
        create_owner_only(path);
        let mut conn = Connection::open(path).map_err(err)?;
        conn.busy_timeout(busy).map_err(err)?;
        conn.set_transaction_behavior(rusqlite::TransactionBehavior::Immediate);
        conn.pragma_update(None, "journal_mode", "WAL")
            .map_err(err)?;
        let level = match sync {
            Sync::Normal => "NORMAL",
            Sync::Full => "FULL",
        };
        conn.pragma_update(None, "synchronous", level)
            .map_err(err)?;
        conn.pragma_update(None, "foreign_keys", "ON")
            .map_err(err)?;
        // 64 MiB of page cache: a person's whole log is read at every advice.
        conn.pragma_update(None, "cache_size", -65536)
            .map_err(err)?;
        schema::migrate(&mut conn)?;
        Ok(Self { conn })
    }

    /// Its statements outside a transaction.
    pub fn db(&self) -> SqliteDb<'_> {
        SqliteDb(&self.conn)
    }

    /// Begins a transaction: IMMEDIATE when it may write, DEFERRED when it
    /// only reads.
    pub fn transaction(&mut self, write: bool) -> Result<SqliteTx<'_>, StoreError> {
        let t = if write {
            self.conn.transaction()
        } else {
            self.conn
                .transaction_with_behavior(rusqlite::TransactionBehavior::Deferred)
        };
        Ok(SqliteTx(t.map_err(err)?))
    }

    /// Runs a statement without waiting for the write lock: SQLite's
    /// busy handler is off for it (`SQLITE_BUSY` at once when another
    /// connection writes), then the connection's busy timeout is back.
    pub fn execute_no_wait(&mut self, q: Q, params: &[Value]) -> Result<usize, StoreError> {
        let wait_ms = self.busy_timeout_ms()?;
        self.conn
            .busy_timeout(std::time::Duration::ZERO)
            .map_err(err)?;
        let out = self.db().execute(q, params);
        let back = self
            .conn
            .busy_timeout(std::time::Duration::from_millis(wait_ms.max(0) as u64))
            .map_err(err);
        let n = out?;
        back?;
        Ok(n)
    }

    /// The connection's busy timeout (ms).
    pub fn busy_timeout_ms(&self) -> Result<i64, StoreError> {
        self.conn
            .pragma_query_value(None, "busy_timeout", |r| r.get(0))
            .map_err(err)
    }

    /// `PRAGMA integrity_check`'s lines.
    pub fn integrity(&self) -> Result<Vec<String>, StoreError> {
        let mut st = self.conn.prepare("PRAGMA integrity_check").map_err(err)?;
        let v = st
            .query_map([], |r| r.get::<_, String>(0))
            .map_err(err)?
            .collect::<Result<Vec<_>, _>>()
            .map_err(err)?;
        Ok(v)
    }

    /// True when SQLite opened the file read-only.
    pub fn is_read_only(&self) -> Result<bool, StoreError> {
        self.conn.is_readonly(rusqlite::MAIN_DB).map_err(err)
    }

    /// The `synchronous` level in force.
    pub fn synchronous(&self) -> Result<i64, StoreError> {
        self.conn
            .pragma_query_value(None, "synchronous", |r| r.get(0))
            .map_err(err)
    }
}

/// Creates a missing store file readable and writable by its owner only
/// (0600 on Unix; SQLite gives its `-wal` and `-shm` files the same
/// mode): it may hold a Nightscout access token. An existing file is left
/// as it is; any other failure is SQLite's to report (a missing folder, no
/// permission) when it opens the file.
fn create_owner_only(path: &Path) {
    let mut o = std::fs::OpenOptions::new();
    o.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut o, 0o600);
    let _ = o.open(path);
}
