//! The PostgreSQL backend: a server shared by any number of `abba`
//! processes (CLI runs, service replicas).
//!
//! Selected by a store "path" that is a URL (`postgres://` or
//! `postgresql://`, as libpq reads it: `postgres://USER@HOST:PORT/DB`, a
//! unix socket as `?host=/run/postgresql`). One [`Pg`] is one connection
//! (the service pools them as it pools SQLite connections), with its
//! prepared statements cached by name.
//!
//! The client is synchronous and must never block a thread that drives
//! asynchronous tasks (the service's handlers, `#[tokio::test]`s): each
//! [`Pg`] owns a thread of its own that holds the client and runs the
//! store's statements one after another, sent to it as jobs; a
//! transaction is `BEGIN` ... `COMMIT` on that connection (`ROLLBACK` when
//! dropped uncommitted).
//!
//! The transactional guarantees are SQLite's: a transaction that may write
//! first takes the store's advisory lock ([`WRITE_LOCK`]), so writers run one
//! after another as SQLite's IMMEDIATE transactions do, and waits at most
//! the busy timeout (`lock_timeout`) before answering busy; a read
//! transaction is a REPEATABLE READ snapshot that takes no lock. A commit
//! returns once the server has it on disk (`synchronous_commit` on).
//!
//! One refinement, since a server can do what a file cannot: a write that
//! concerns one person only (an app's events, answers, a change of that
//! person's settings: [`Pg::transaction_for`]) takes the store's lock
//! *shared* and that person's lock ([`PERSON_LOCK`]) exclusive. Writes for
//! two persons then run, and commit, side by side (the server flushes
//! their commits together), while a write of the whole store (an import,
//! a new person, a token, a migration's data) still waits for every one
//! of them and they for it. What SQLite's one writer guaranteed holds per
//! person: nothing comes between a person's writes, and a live advisor's
//! revision check under the person's lock sees every committed write for
//! that person.

pub mod schema;
pub mod sql;

use super::{Db, DbError, DbErrorKind, Row, RowSink, Value, Q};
use crate::error::StoreError;
use postgres::fallible_iterator::FallibleIterator;
use postgres::types::{IsNull, ToSql, Type};
use postgres::{GenericClient, NoTls, Statement};
use std::cell::RefCell;
use std::collections::HashMap;
use std::sync::{mpsc, Arc, Mutex, PoisonError};

/// The advisory lock every write transaction of a store holds: one per
/// schema (a store is the schema its search path names), so stores of one
/// server do not wait for each other.
pub const WRITE_LOCK: &str =
    "SELECT pg_advisory_xact_lock(hashtext('abba write ' || current_schema()))";

/// The store's lock taken shared, then person `$1`'s exclusive (see the
/// module doc): the write transaction of one person's data.
pub const PERSON_LOCK: &str =
    "SELECT pg_advisory_xact_lock_shared(hashtext('abba write ' || current_schema())); \
     SELECT pg_advisory_xact_lock(hashtext('abba person ' || current_schema()), ";

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
type Cache = Mutex<HashMap<Q, Statement>>;

fn prepared<C: GenericClient>(c: &mut C, cache: &Cache, q: Q) -> Result<Statement, StoreError> {
    if let Some(s) = cache.lock().unwrap_or_else(PoisonError::into_inner).get(&q) {
        return Ok(s.clone());
    }
    let s = c.prepare(&sql::text(q)).map_err(err)?;
    cache
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .insert(q, s.clone());
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

/// Statements on a client or a transaction of it (a migration's, on the
/// connection's own thread).
pub struct PgDb<'a, C: GenericClient> {
    c: RefCell<&'a mut C>,
    cache: Cache,
}

impl<'a, C: GenericClient> PgDb<'a, C> {
    /// Statements on `c`, prepared afresh.
    pub fn new(c: &'a mut C) -> Self {
        Self {
            c: RefCell::new(c),
            cache: Mutex::new(HashMap::new()),
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

/// Work for the connection's thread.
type Job = Box<dyn FnOnce(&mut postgres::Client) + Send>;

fn gone() -> StoreError {
    StoreError::Db(DbError {
        backend: "postgres",
        kind: DbErrorKind::Connect,
        message: "the connection's thread ended".into(),
    })
}

/// One connection to a PostgreSQL store (its client on a thread of its
/// own, which ends when this is dropped).
pub struct Pg {
    jobs: mpsc::Sender<Job>,
    cache: Arc<Cache>,
    /// Whether [`Pg::try_lock`] took a session lock (released when the
    /// store is dropped).
    claimed: std::sync::atomic::AtomicBool,
}

/// A transaction of [`Pg`] (rolled back when dropped uncommitted).
pub struct PgTx<'a> {
    pg: &'a Pg,
    done: bool,
}

impl Pg {
    /// Connects to `url` (on the connection's own thread), sets the busy
    /// timeout (how long a writer waits for another) and applies the
    /// migrations.
    pub fn open(url: &str, busy: std::time::Duration) -> Result<Self, StoreError> {
        let config: postgres::Config = url.parse().map_err(|e: postgres::Error| {
            StoreError::invalid("--db", format!("not a PostgreSQL URL this abba reads: {e}"))
        })?;
        let (jobs, inbox) = mpsc::channel::<Job>();
        let (ready, opened) = mpsc::channel::<Result<(), StoreError>>();
        std::thread::Builder::new()
            .name("abba-postgres".into())
            .spawn(move || {
                let connected = config.connect(NoTls).map_err(|e| {
                    StoreError::Db(DbError {
                        backend: "postgres",
                        kind: DbErrorKind::Connect,
                        message: format!("cannot connect to the PostgreSQL server: {e}"),
                    })
                });
                let mut client = match connected {
                    Ok(c) => c,
                    Err(e) => {
                        let _ = ready.send(Err(e));
                        return;
                    }
                };
                let set = client
                    .batch_execute(&format!(
                        "SET lock_timeout = {}; SET client_min_messages = warning; SET synchronous_commit = on",
                        busy.as_millis().max(1)
                    ))
                    .map_err(err)
                    .and_then(|()| schema::migrate(&mut client));
                let ok = set.is_ok();
                let _ = ready.send(set);
                if ok {
                    for job in inbox {
                        job(&mut client);
                    }
                }
            })
            .map_err(|e| StoreError::corrupt("connection thread", e))?;
        opened.recv().map_err(|_| gone())??;
        Ok(Self {
            jobs,
            cache: Arc::new(Mutex::new(HashMap::new())),
            claimed: std::sync::atomic::AtomicBool::new(false),
        })
    }

    /// Runs `f` on the connection's thread and waits for its answer.
    fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut postgres::Client, &Cache) -> Result<R, StoreError> + Send + 'static,
    ) -> Result<R, StoreError> {
        let (tx, rx) = mpsc::channel();
        let cache = Arc::clone(&self.cache);
        self.jobs
            .send(Box::new(move |c| {
                let _ = tx.send(f(c, &cache));
            }))
            .map_err(|_| gone())?;
        rx.recv().map_err(|_| gone())?
    }

    fn batch(&self, sql: &'static str) -> Result<(), StoreError> {
        self.call(move |c, _| c.batch_execute(sql).map_err(err))
    }

    /// Begins a transaction: one that may write takes [`WRITE_LOCK`]
    /// first; one that only reads is a read-only snapshot.
    pub fn transaction(&mut self, write: bool) -> Result<PgTx<'_>, StoreError> {
        if write {
            self.batch("BEGIN")?;
            let tx = PgTx {
                pg: self,
                done: false,
            };
            // (Dropped on an error: rolled back.)
            tx.pg.batch(WRITE_LOCK)?;
            Ok(tx)
        } else {
            self.batch("BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY")?;
            Ok(PgTx {
                pg: self,
                done: false,
            })
        }
    }

    /// Begins a transaction that writes only person `person`'s data: the
    /// store's lock shared and the person's exclusive ([`PERSON_LOCK`]), so
    /// that writes for other persons go on beside it.
    pub fn transaction_for(&mut self, person: i64) -> Result<PgTx<'_>, StoreError> {
        self.batch("BEGIN")?;
        let tx = PgTx {
            pg: self,
            done: false,
        };
        // (32 bits of the id: two persons sharing a lock only wait for
        // each other. Dropped on an error: rolled back.)
        let sql = format!("{PERSON_LOCK}{})", person as i32);
        tx.pg.call(move |c, _| c.batch_execute(&sql).map_err(err))?;
        Ok(tx)
    }

    /// True when the server only reads (a standby, or a read-only default).
    pub fn is_read_only(&self) -> Result<bool, StoreError> {
        self.call(|c, _| {
            let r = c
                .query_one("SHOW transaction_read_only", &[])
                .map_err(err)?;
            Ok(r.try_get::<_, String>(0).map_err(err)? == "on")
        })
    }

    /// Takes the session-level advisory lock `key` if no other session
    /// holds it (background work done by one process at a time; released
    /// when this store is dropped); false when another holds it.
    pub fn try_lock(&self, key: i64) -> Result<bool, StoreError> {
        // (The store's schema, and 32 bits of the key.)
        let key = key as i32;
        let taken = self.call(move |c, _| {
            let r = c
                .query_one(
                    "SELECT pg_try_advisory_lock(hashtext(current_schema()), $1)",
                    &[&key],
                )
                .map_err(err)?;
            r.try_get::<_, bool>(0).map_err(err)
        })?;
        if taken {
            self.claimed
                .store(true, std::sync::atomic::Ordering::Relaxed);
        }
        Ok(taken)
    }
}

impl Drop for Pg {
    /// Releases the session locks [`Pg::try_lock`] took, and waits for the
    /// server to say so. Closing the connection alone releases them only
    /// when the server's backend exits, after this process has gone on: a
    /// claim made right after (the next refit of the same person) was
    /// refused at random under load. (Nothing to report on failure: the
    /// connection's end releases them too.)
    fn drop(&mut self) {
        if self.claimed.load(std::sync::atomic::Ordering::Relaxed) {
            let _ = self.batch("SELECT pg_advisory_unlock_all()");
        }
    }
}

/// A part of a streamed result ([`Pg`]'s `each_row`).
enum Part {
    Rows(Vec<Row>),
    End,
    Failed(StoreError),
}

/// Rows a streamed result sends at a time.
const STREAM_CHUNK: usize = 1024;

impl Db for Pg {
    fn execute(&self, q: Q, p: &[Value]) -> Result<usize, StoreError> {
        let p = p.to_vec();
        self.call(move |c, cache| execute(c, cache, q, &p))
    }
    fn rows(&self, q: Q, p: &[Value]) -> Result<Vec<Row>, StoreError> {
        let p = p.to_vec();
        self.call(move |c, cache| rows(c, cache, q, &p))
    }
    /// Streams: the connection's thread reads the rows as the server sends
    /// them and passes them on a few at a time (at most two parts wait), so
    /// a person's whole log is never held at once.
    fn each_row(&self, q: Q, p: &[Value], f: &mut RowSink<'_>) -> Result<(), StoreError> {
        let p = p.to_vec();
        let (tx, rx) = mpsc::sync_channel::<Part>(2);
        let cache = Arc::clone(&self.cache);
        self.jobs
            .send(Box::new(move |c| {
                let run = |c: &mut postgres::Client| -> Result<bool, StoreError> {
                    let st = prepared(c, &cache, q)?;
                    let mut it = c.query_raw(&st, params(&p)).map_err(err)?;
                    let mut chunk = Vec::with_capacity(STREAM_CHUNK);
                    while let Some(r) = it.next().map_err(err)? {
                        chunk.push(row_of(&r)?);
                        if chunk.len() == STREAM_CHUNK
                            && tx.send(Part::Rows(std::mem::take(&mut chunk))).is_err()
                        {
                            // The caller stopped reading (its callback failed).
                            return Ok(false);
                        }
                    }
                    Ok(chunk.is_empty() || tx.send(Part::Rows(chunk)).is_ok())
                };
                let _ = match run(c) {
                    Ok(true) => tx.send(Part::End),
                    Ok(false) => Ok(()),
                    Err(e) => tx.send(Part::Failed(e)),
                };
            }))
            .map_err(|_| gone())?;
        loop {
            match rx.recv().map_err(|_| gone())? {
                Part::Rows(rows) => rows.into_iter().try_for_each(&mut *f)?,
                Part::End => return Ok(()),
                Part::Failed(e) => return Err(e),
            }
        }
    }
    fn insert_id(&self, q: Q, p: &[Value]) -> Result<i64, StoreError> {
        let p = p.to_vec();
        self.call(move |c, cache| insert_id(c, cache, q, &p))
    }
}

impl PgTx<'_> {
    /// Commits.
    pub fn commit(mut self) -> Result<(), StoreError> {
        self.done = true;
        self.pg.batch("COMMIT")
    }
}

impl Drop for PgTx<'_> {
    fn drop(&mut self) {
        if !self.done {
            // Nothing to tell anyone: a failed rollback ends with the
            // connection, which rolls back too.
            let _ = self.pg.batch("ROLLBACK");
        }
    }
}

impl Db for PgTx<'_> {
    fn execute(&self, q: Q, p: &[Value]) -> Result<usize, StoreError> {
        self.pg.execute(q, p)
    }
    fn rows(&self, q: Q, p: &[Value]) -> Result<Vec<Row>, StoreError> {
        self.pg.rows(q, p)
    }
    fn each_row(&self, q: Q, p: &[Value], f: &mut RowSink<'_>) -> Result<(), StoreError> {
        self.pg.each_row(q, p, f)
    }
    fn insert_id(&self, q: Q, p: &[Value]) -> Result<i64, StoreError> {
        self.pg.insert_id(q, p)
    }
}
