//! The PostgreSQL backend: a server shared by any number of `abba`
//! processes (CLI runs, service replicas).
//!
//! Selected by a store "path" that is a URL (`postgres://` or
//! `postgresql://`, as libpq reads it: `postgres://USER@HOST:PORT/DB`, a
//! unix socket as `?host=/run/postgresql`). One [`Pg`] is one connection
//! (the service pools them as it pools SQLite connections), with its
//! prepared statements cached by name.
//!
//! The transactional guarantees are SQLite's: a transaction that may write
//! first takes the store's advisory lock ([`WRITE_LOCK`]), so writers run one
//! after another as SQLite's IMMEDIATE transactions do, and waits at most
//! the busy timeout (`lock_timeout`) before answering busy; a read
//! transaction is a REPEATABLE READ snapshot that takes no lock. A commit
//! returns once the server has it on disk (`synchronous_commit` on).

pub mod schema;
pub mod sql;

use super::{Db, DbError, DbErrorKind, Row, Value, Q};
use crate::error::StoreError;
use postgres::types::{IsNull, ToSql, Type};
use postgres::{GenericClient, NoTls, Statement};
use std::cell::RefCell;
use std::collections::HashMap;

/// The advisory lock every write transaction of a store holds: one per
/// schema (a store is the schema its search path names), so stores of one
/// server do not wait for each other.
pub const WRITE_LOCK: &str =
    "SELECT pg_advisory_xact_lock(hashtext('abba write ' || current_schema()))";

/// True when `db` names a PostgreSQL database rather than a file.
pub fn is_url(db: &str) -> bool {
    db.starts_with("postgres://") || db.starts_with("postgresql://")
}

/// A PostgreSQL error as the store's [`StoreError::Db`], the server's
/// message kept.
pub(crate) fn err(e: postgres::Error) -> StoreError {
    use postgres::error::SqlState;
    let kind = match e.code() {
        Some(c)
            if *c == SqlState::LOCK_NOT_AVAILABLE
                || *c == SqlState::T_R_SERIALIZATION_FAILURE
                || *c == SqlState::T_R_DEADLOCK_DETECTED
                || *c == SqlState::QUERY_CANCELED =>
        {
            DbErrorKind::Busy
        }
        Some(c) if *c == SqlState::READ_ONLY_SQL_TRANSACTION => DbErrorKind::ReadOnly,
        Some(c) if c.code().starts_with("23") => DbErrorKind::Constraint,
        Some(c) if c.code().starts_with("08") => DbErrorKind::Connect,
        None if e.is_closed() => DbErrorKind::Connect,
        _ => DbErrorKind::Other,
    };
    let message = match e.as_db_error() {
        Some(d) => match d.detail() {
            Some(detail) => format!("{} ({detail})", d.message()),
            None => d.message().to_string(),
        },
        None => e.to_string(),
    };
    StoreError::Db(DbError {
        backend: "postgres",
        kind,
        message,
    })
}

impl ToSql for Value {
    fn to_sql(
        &self,
        ty: &Type,
        out: &mut bytes::BytesMut,
    ) -> Result<IsNull, Box<dyn std::error::Error + Sync + Send>> {
        // The server says which type each parameter is; the value is
        // converted to it (SQLite would take any).
        match self {
            Value::Null => Ok(IsNull::Yes),
            Value::Int(v) => match *ty {
                Type::INT8 => v.to_sql(ty, out),
                Type::INT4 => i32::try_from(*v)?.to_sql(ty, out),
                Type::INT2 => i16::try_from(*v)?.to_sql(ty, out),
                Type::BOOL => (*v != 0).to_sql(ty, out),
                Type::FLOAT8 => (*v as f64).to_sql(ty, out),
                _ => Err(format!("an integer given for a parameter of type {ty}").into()),
            },
            Value::Real(v) => match *ty {
                Type::FLOAT8 => v.to_sql(ty, out),
                Type::FLOAT4 => (*v as f32).to_sql(ty, out),
                _ => Err(format!("a number given for a parameter of type {ty}").into()),
            },
            Value::Text(v) => v.as_str().to_sql(ty, out),
            Value::Blob(v) => v.as_slice().to_sql(ty, out),
        }
    }

    fn accepts(_: &Type) -> bool {
        true
    }

    postgres::types::to_sql_checked!();
}

fn row_of(r: &postgres::Row) -> Result<Row, StoreError> {
    let mut out = Vec::with_capacity(r.len());
    for (i, c) in r.columns().iter().enumerate() {
        let v = match *c.type_() {
            Type::INT8 => r.try_get::<_, Option<i64>>(i).map_err(err)?.map(Value::Int),
            Type::INT4 => r
                .try_get::<_, Option<i32>>(i)
                .map_err(err)?
                .map(|v| Value::Int(v.into())),
            Type::INT2 => r
                .try_get::<_, Option<i16>>(i)
                .map_err(err)?
                .map(|v| Value::Int(v.into())),
            Type::BOOL => r
                .try_get::<_, Option<bool>>(i)
                .map_err(err)?
                .map(Value::from),
            Type::FLOAT8 => r
                .try_get::<_, Option<f64>>(i)
                .map_err(err)?
                .map(Value::Real),
            Type::FLOAT4 => r
                .try_get::<_, Option<f32>>(i)
                .map_err(err)?
                .map(|v| Value::Real(v.into())),
            Type::TEXT | Type::VARCHAR | Type::NAME | Type::BPCHAR => r
                .try_get::<_, Option<String>>(i)
                .map_err(err)?
                .map(Value::Text),
            Type::BYTEA => r
                .try_get::<_, Option<Vec<u8>>>(i)
                .map_err(err)?
                .map(Value::Blob),
            ref t => {
                return Err(StoreError::corrupt(
                    "row",
                    format!(
                        "column {} has type {t}, which the store does not read",
                        c.name()
                    ),
                ))
            }
        };
        out.push(v.unwrap_or(Value::Null));
    }
    Ok(Row(out))
}

/// Prepared statements of one connection, by name.
type Cache = RefCell<HashMap<Q, Statement>>;

fn prepared<C: GenericClient>(c: &mut C, cache: &Cache, q: Q) -> Result<Statement, StoreError> {
    if let Some(s) = cache.borrow().get(&q) {
        return Ok(s.clone());
    }
    let s = c.prepare(&sql::text(q)).map_err(err)?;
    cache.borrow_mut().insert(q, s.clone());
    Ok(s)
}

fn params(p: &[Value]) -> Vec<&(dyn ToSql + Sync)> {
    p.iter().map(|v| v as &(dyn ToSql + Sync)).collect()
}

fn execute<C: GenericClient>(
    c: &mut C,
    cache: &Cache,
    q: Q,
    p: &[Value],
) -> Result<usize, StoreError> {
    let st = prepared(c, cache, q)?;
    Ok(c.execute(&st, &params(p)).map_err(err)? as usize)
}

fn rows<C: GenericClient>(
    c: &mut C,
    cache: &Cache,
    q: Q,
    p: &[Value],
) -> Result<Vec<Row>, StoreError> {
    let st = prepared(c, cache, q)?;
    c.query(&st, &params(p))
        .map_err(err)?
        .iter()
        .map(row_of)
        .collect()
}

fn insert_id<C: GenericClient>(
    c: &mut C,
    cache: &Cache,
    q: Q,
    p: &[Value],
) -> Result<i64, StoreError> {
    if !sql::returning_id(q) {
        return Err(StoreError::corrupt(
            "statement",
            format!("{q:?} returns no id"),
        ));
    }
    let st = prepared(c, cache, q)?;
    let r = c.query_one(&st, &params(p)).map_err(err)?;
    r.try_get::<_, i64>(0).map_err(err)
}

/// Statements on a client or a transaction of it.
pub struct PgDb<'a, C: GenericClient> {
    c: RefCell<&'a mut C>,
    cache: Cache,
}

impl<'a, C: GenericClient> PgDb<'a, C> {
    /// Statements on `c`, prepared afresh (a migration's).
    pub fn new(c: &'a mut C) -> Self {
        Self {
            c: RefCell::new(c),
            cache: RefCell::new(HashMap::new()),
        }
    }
}

impl<C: GenericClient> Db for PgDb<'_, C> {
    fn execute(&self, q: Q, p: &[Value]) -> Result<usize, StoreError> {
        execute(&mut **self.c.borrow_mut(), &self.cache, q, p)
    }
    fn rows(&self, q: Q, p: &[Value]) -> Result<Vec<Row>, StoreError> {
        rows(&mut **self.c.borrow_mut(), &self.cache, q, p)
    }
    fn insert_id(&self, q: Q, p: &[Value]) -> Result<i64, StoreError> {
        insert_id(&mut **self.c.borrow_mut(), &self.cache, q, p)
    }
}

/// One connection to a PostgreSQL store.
pub struct Pg {
    client: RefCell<postgres::Client>,
    cache: Cache,
}

/// A transaction of [`Pg`] (rolled back when dropped uncommitted).
pub struct PgTx<'a> {
    tx: RefCell<postgres::Transaction<'a>>,
    cache: &'a Cache,
}

impl Pg {
    /// Connects to `url`, sets the busy timeout (how long a writer waits
    /// for another) and applies the migrations.
    pub fn open(url: &str, busy: std::time::Duration) -> Result<Self, StoreError> {
        let config: postgres::Config = url.parse().map_err(|e: postgres::Error| {
            StoreError::invalid("--db", format!("not a PostgreSQL URL this abba reads: {e}"))
        })?;
        let mut client = config.connect(NoTls).map_err(|e| {
            StoreError::Db(DbError {
                backend: "postgres",
                kind: DbErrorKind::Connect,
                message: format!("cannot connect to the PostgreSQL server: {e}"),
            })
        })?;
        client
            .batch_execute(&format!(
                "SET lock_timeout = {}; SET client_min_messages = warning; SET synchronous_commit = on",
                busy.as_millis().max(1)
            ))
            .map_err(err)?;
        schema::migrate(&mut client)?;
        Ok(Self {
            client: RefCell::new(client),
            cache: RefCell::new(HashMap::new()),
        })
    }

    /// Begins a transaction: one that may write takes [`WRITE_LOCK`]
    /// first; one that only reads is a read-only snapshot.
    pub fn transaction(&mut self, write: bool) -> Result<PgTx<'_>, StoreError> {
        let Pg { client, cache } = self;
        let client = client.get_mut();
        let tx = if write {
            let mut tx = client.transaction().map_err(err)?;
            tx.execute(WRITE_LOCK, &[]).map_err(err)?;
            tx
        } else {
            client
                .build_transaction()
                .isolation_level(postgres::IsolationLevel::RepeatableRead)
                .read_only(true)
                .start()
                .map_err(err)?
        };
        Ok(PgTx {
            tx: RefCell::new(tx),
            cache,
        })
    }

    /// True when the server only reads (a standby, or a read-only default).
    pub fn is_read_only(&self) -> Result<bool, StoreError> {
        let r = self
            .client
            .borrow_mut()
            .query_one("SHOW transaction_read_only", &[])
            .map_err(err)?;
        Ok(r.try_get::<_, String>(0).map_err(err)? == "on")
    }

    /// Takes the session-level advisory lock `key` if no other session
    /// holds it (background work done by one process at a time; released
    /// when this connection closes); false when another holds it.
    pub fn try_lock(&self, key: i64) -> Result<bool, StoreError> {
        // (The store's schema, and 32 bits of the key.)
        let key = key as i32;
        let r = self
            .client
            .borrow_mut()
            .query_one(
                "SELECT pg_try_advisory_lock(hashtext(current_schema()), $1)",
                &[&key],
            )
            .map_err(err)?;
        r.try_get::<_, bool>(0).map_err(err)
    }
}

impl Db for Pg {
    fn execute(&self, q: Q, p: &[Value]) -> Result<usize, StoreError> {
        execute(&mut *self.client.borrow_mut(), &self.cache, q, p)
    }
    fn rows(&self, q: Q, p: &[Value]) -> Result<Vec<Row>, StoreError> {
        rows(&mut *self.client.borrow_mut(), &self.cache, q, p)
    }
    fn insert_id(&self, q: Q, p: &[Value]) -> Result<i64, StoreError> {
        insert_id(&mut *self.client.borrow_mut(), &self.cache, q, p)
    }
}

impl PgTx<'_> {
    /// Commits.
    pub fn commit(self) -> Result<(), StoreError> {
        self.tx.into_inner().commit().map_err(err)
    }
}

impl Db for PgTx<'_> {
    fn execute(&self, q: Q, p: &[Value]) -> Result<usize, StoreError> {
        execute(&mut *self.tx.borrow_mut(), self.cache, q, p)
    }
    fn rows(&self, q: Q, p: &[Value]) -> Result<Vec<Row>, StoreError> {
        rows(&mut *self.tx.borrow_mut(), self.cache, q, p)
    }
    fn insert_id(&self, q: Q, p: &[Value]) -> Result<i64, StoreError> {
        insert_id(&mut *self.tx.borrow_mut(), self.cache, q, p)
    }
}
