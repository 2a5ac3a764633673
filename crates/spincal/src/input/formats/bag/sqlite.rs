//! ROS 2 bags in sqlite3 storage (`.db3`): a `topics` table (`id`, `name`, `type`,
//! `serialization_format`) and a `messages` table (`id`, `topic_id`, `timestamp` in ns, `data`).

use std::collections::HashMap;
use std::path::Path;

use rusqlite::{Connection, OpenFlags};

use super::{BagError, Collector};

fn sql_error(file: &str, what: &str) -> impl Fn(rusqlite::Error) -> BagError {
    let (file, what) = (file.to_string(), what.to_string());
    move |source| BagError::Sqlite {
        file: file.clone(),
        what: what.clone(),
        source,
    }
}

/// Reads a `.db3` file in place (read-only).
pub fn scan_path(path: &Path, file: &str, c: &mut Collector) -> Result<(), BagError> {
    let conn = Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(sql_error(file, "cannot open"))?;
    scan_connection(&conn, file, c)
}

/// Reads a `.db3` database held in memory.
pub fn scan_bytes(bytes: &[u8], file: &str, c: &mut Collector) -> Result<(), BagError> {
    if bytes.len() > i32::MAX as usize {
        return Err(BagError::Unsupported {
            file: file.into(),
            what: "an sqlite3 bag over 2 GiB is read from its path, not from memory".into(),
        });
    }
    let mut conn = Connection::open_in_memory().map_err(sql_error(file, "cannot open"))?;
    conn.deserialize_read_exact(rusqlite::MAIN_DB, bytes, bytes.len(), true)
        .map_err(sql_error(file, "cannot load the database"))?;
    scan_connection(&conn, file, c)
}

fn scan_connection(conn: &Connection, file: &str, c: &mut Collector) -> Result<(), BagError> {
    let mut topics: HashMap<i64, usize> = HashMap::new();
    {
        let mut st = conn
            .prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id")
            .map_err(sql_error(file, "reading table `topics`"))?;
        let mut rows = st.query([]).map_err(sql_error(file, "reading table `topics`"))?;
        while let Some(row) = rows.next().map_err(sql_error(file, "reading table `topics`"))? {
            let id: i64 = row.get(0).map_err(sql_error(file, "topics.id"))?;
            let at = format!("topics row id {id}");
            let name: String = row.get(1).map_err(sql_error(file, &format!("{at}: name")))?;
            let ty: String = row.get(2).map_err(sql_error(file, &format!("{at}: type")))?;
            let ser: String = row
                .get(3)
                .map_err(sql_error(file, &format!("{at}: serialization_format")))?;
            let t = c.topic(&name, &ty, &ser);
            topics.insert(id, t);
        }
    }
    let what = "reading table `messages`";
    let mut st = conn
        .prepare("SELECT id, topic_id, timestamp, data FROM messages ORDER BY id")
        .map_err(sql_error(file, what))?;
    let mut rows = st.query([]).map_err(sql_error(file, what))?;
    while let Some(row) = rows.next().map_err(sql_error(file, what))? {
        let id: i64 = row.get(0).map_err(sql_error(file, "messages.id"))?;
        let at = format!("messages row id {id}");
        let topic_id: i64 = row.get(1).map_err(sql_error(file, &format!("{at}: topic_id")))?;
        let stamp: i64 = row.get(2).map_err(sql_error(file, &format!("{at}: timestamp")))?;
        let data = row.get_ref(3).map_err(sql_error(file, &format!("{at}: data")))?;
        let data = data.as_blob().map_err(|e| BagError::Corrupt {
            file: file.into(),
            at: at.clone(),
            what: format!("data is not a blob: {e}"),
        })?;
        let Some(&t) = topics.get(&topic_id) else {
            return Err(BagError::Corrupt {
                file: file.into(),
                at,
                what: format!("topic_id {topic_id} is not in table `topics`"),
            });
        };
        c.message(t, stamp.max(0) as u64, data, &|| at.clone());
    }
    Ok(())
}
