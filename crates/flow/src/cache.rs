//! The content-addressed on-disk cache (DESIGN §4).
//!
//! Layout under the cache folder (default `<graph folder>/.crestflow/cache`):
//! - `entries/<key>.json`: one per node key: the output digests, sizes and type names, and the
//!   content hashes of the files the node wrote;
//! - `blobs/<d0d1>/<digest>`: one per output digest, the postcard encoding of the value;
//! - `runs/<graph id>.json`: the last two run records of each graph (for `why` and `gc`);
//! - `statmemo.json`: (path, size, mtime) -> content hash, so unchanged files are not re-hashed.
//!
//! Every write goes to a temporary file that is renamed into place, so a crash never leaves a
//! half-written entry. Unreadable entries and blobs are misses, never crashes.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

/// What a cache entry records about one output port.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutputMeta {
    pub digest: String,
    pub size: u64,
    pub ty: String,
    /// Values of at most [`INLINE_MAX`] bytes are kept in the entry (hex) instead of a blob
    /// file: one file per node instead of two for small outputs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inline: Option<String>,
}

/// The largest encoded value stored inside its entry.
pub const INLINE_MAX: usize = 256;

/// Lower-case hex of bytes.
pub fn to_hex(bytes: &[u8]) -> String {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let mut s = String::with_capacity(bytes.len() * 2);
    for b in bytes {
        s.push(DIGITS[(b >> 4) as usize] as char);
        s.push(DIGITS[(b & 15) as usize] as char);
    }
    s
}

/// Bytes of lower- or upper-case hex; `None` when it is not hex.
pub fn from_hex(s: &str) -> Option<Vec<u8>> {
    if !s.len().is_multiple_of(2) {
        return None;
    }
    s.as_bytes()
        .chunks(2)
        .map(|c| {
            let h = (c[0] as char).to_digit(16)?;
            let l = (c[1] as char).to_digit(16)?;
            Some((h * 16 + l) as u8)
        })
        .collect()
}

/// A cache entry: the outputs of one node key.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    pub kind: String,
    pub version: u32,
    pub outputs: BTreeMap<String, OutputMeta>,
    /// (resolved path, content hash) of every file the node wrote.
    pub output_files: Vec<(String, String)>,
}

/// How one input port was fed in a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputRecord {
    /// `node.port` of the upstream output.
    pub from: String,
    pub digest: String,
}

/// What a run did with one node, kept for `crestflow why`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeRecord {
    pub kind: String,
    pub version: u32,
    pub key: String,
    pub params: String,
    pub inputs: BTreeMap<String, InputRecord>,
    /// Input files: resolved path -> content hash (`missing` when unreadable).
    pub files: BTreeMap<String, String>,
    pub outputs: BTreeMap<String, String>,
    pub status: String,
    pub reason: String,
    pub ms: f64,
}

/// One run of one graph.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    pub unix_time: u64,
    pub nodes: BTreeMap<String, NodeRecord>,
}

/// The last runs of a graph (oldest first, at most two).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RunHistory {
    pub graph: String,
    pub runs: Vec<RunRecord>,
}

/// Sizes of a cache folder.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CacheStats {
    pub entries: usize,
    pub blobs: usize,
    pub blob_bytes: u64,
    pub entry_bytes: u64,
    pub graphs: usize,
}

/// What `gc` removed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GcStats {
    pub entries_removed: usize,
    pub blobs_removed: usize,
    pub bytes_freed: u64,
}

/// A cache folder.
#[derive(Debug)]
pub struct CacheStore {
    dir: PathBuf,
    memo: Mutex<StatMemo>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
struct StatMemo {
    files: BTreeMap<String, (u64, u128, String)>,
    #[serde(skip)]
    dirty: bool,
}

static TMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    fs::create_dir_all(dir)?;
    let n = TMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.{n}.tmp", std::process::id()));
    let res = fs::write(&tmp, bytes).and_then(|_| fs::rename(&tmp, path));
    if res.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    res
}

/// Current time in seconds since the epoch.
pub fn unix_now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// An error unless `path` is a regular file (or a link to one). Reading a device such as
/// `/dev/zero`, or a pipe nobody writes, would never end; this is checked before opening,
/// since opening a pipe already waits for a writer.
pub(crate) fn ensure_regular_file(path: &Path) -> io::Result<()> {
    if fs::metadata(path)?.is_file() {
        Ok(())
    } else {
        Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "not a regular file (a folder, a device or a pipe)",
        ))
    }
}

/// blake3 of a file's content, hex. Only regular files (`ensure_regular_file`); the node
/// that reads the path reports the error.
pub fn hash_file(path: &Path) -> io::Result<String> {
    ensure_regular_file(path)?;
    let mut h = blake3::Hasher::new();
    let mut f = fs::File::open(path)?;
    io::copy(&mut f, &mut h)?;
    Ok(h.finalize().to_hex().to_string())
}

impl CacheStore {
    /// Opens (creating) a cache folder.
    pub fn open(dir: &Path) -> io::Result<CacheStore> {
        fs::create_dir_all(dir.join("entries"))?;
        fs::create_dir_all(dir.join("blobs"))?;
        fs::create_dir_all(dir.join("runs"))?;
        let memo = fs::read(dir.join("statmemo.json"))
            .ok()
            .and_then(|b| serde_json::from_slice::<StatMemo>(&b).ok())
            .unwrap_or_default();
        Ok(CacheStore {
            dir: dir.to_path_buf(),
            memo: Mutex::new(memo),
        })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn entry_path(&self, key: &str) -> PathBuf {
        self.dir.join("entries").join(format!("{key}.json"))
    }

    fn blob_path(&self, digest: &str) -> PathBuf {
        self.dir
            .join("blobs")
            .join(digest.get(..2).unwrap_or("xx"))
            .join(digest)
    }

    /// `Ok(None)` when there is no entry; `Err(why)` when it exists but cannot be read.
    pub fn read_entry(&self, key: &str) -> Result<Option<Entry>, String> {
        match fs::read(self.entry_path(key)) {
            Ok(bytes) => serde_json::from_slice(&bytes)
                .map(Some)
                .map_err(|e| format!("cache entry {key} is corrupt ({e})")),
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(format!("cache entry {key} cannot be read ({e})")),
        }
    }

    pub fn write_entry(&self, key: &str, entry: &Entry) -> io::Result<()> {
        let bytes = serde_json::to_vec(entry).map_err(io::Error::other)?;
        write_atomic(&self.entry_path(key), &bytes)
    }

    pub fn has_blob(&self, digest: &str) -> bool {
        self.blob_path(digest).is_file()
    }

    /// Stores a blob unless one with that digest exists (it then holds the same bytes).
    pub fn write_blob(&self, digest: &str, bytes: &[u8]) -> io::Result<()> {
        let p = self.blob_path(digest);
        if p.is_file() {
            return Ok(());
        }
        write_atomic(&p, bytes)
    }

    /// Overwrites a blob (after its stored copy was found corrupt).
    pub fn repair_blob(&self, digest: &str, bytes: &[u8]) -> io::Result<()> {
        write_atomic(&self.blob_path(digest), bytes)
    }

    /// Reads a blob and checks it against its digest.
    pub fn read_blob(&self, digest: &str) -> Result<Vec<u8>, String> {
        let bytes = fs::read(self.blob_path(digest))
            .map_err(|e| format!("cache blob {digest} cannot be read ({e})"))?;
        let actual = blake3::hash(&bytes).to_hex();
        if actual.as_str() != digest {
            return Err(format!(
                "cache blob {digest} is corrupt (its content hashes to {actual})"
            ));
        }
        Ok(bytes)
    }

    /// The content hash of a file, reusing the stored hash when size and mtime are unchanged.
    pub fn file_hash(&self, path: &Path) -> io::Result<String> {
        let meta = fs::metadata(path)?;
        let mtime = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        let key = path.to_string_lossy().into_owned();
        if let Ok(memo) = self.memo.lock() {
            if let Some((size, mt, hash)) = memo.files.get(&key) {
                if *size == meta.len() && *mt == mtime && mtime != 0 {
                    return Ok(hash.clone());
                }
            }
        }
        let hash = hash_file(path)?;
        if let Ok(mut memo) = self.memo.lock() {
            memo.files.insert(key, (meta.len(), mtime, hash.clone()));
            memo.dirty = true;
        }
        Ok(hash)
    }

    /// Saves the stat memo if it changed.
    pub fn save_memo(&self) -> io::Result<()> {
        let Ok(mut memo) = self.memo.lock() else {
            return Ok(());
        };
        if !memo.dirty {
            return Ok(());
        }
        let bytes = serde_json::to_vec(&*memo).map_err(io::Error::other)?;
        write_atomic(&self.dir.join("statmemo.json"), &bytes)?;
        memo.dirty = false;
        Ok(())
    }

    fn history_path(&self, graph_id: &str) -> PathBuf {
        self.dir.join("runs").join(format!(
            "{}.json",
            blake3::hash(graph_id.as_bytes()).to_hex()
        ))
    }

    /// The run history of a graph (identified by its absolute file path or a chosen name).
    pub fn history(&self, graph_id: &str) -> RunHistory {
        fs::read(self.history_path(graph_id))
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_else(|| RunHistory {
                graph: graph_id.to_string(),
                runs: Vec::new(),
            })
    }

    /// Appends a run record, keeping the last two.
    pub fn push_run(&self, graph_id: &str, run: RunRecord) -> io::Result<()> {
        let mut h = self.history(graph_id);
        h.graph = graph_id.to_string();
        h.runs.push(run);
        while h.runs.len() > 2 {
            h.runs.remove(0);
        }
        let bytes = serde_json::to_vec(&h).map_err(io::Error::other)?;
        write_atomic(&self.history_path(graph_id), &bytes)
    }

    fn histories(&self) -> Vec<RunHistory> {
        let Ok(rd) = fs::read_dir(self.dir.join("runs")) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for e in rd.flatten() {
            if let Some(h) = fs::read(e.path())
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok())
            {
                out.push(h);
            }
        }
        out
    }

    pub fn stats(&self) -> CacheStats {
        let mut s = CacheStats::default();
        for (p, len) in files_under(&self.dir.join("entries")) {
            if !is_tmp(&p) {
                s.entries += 1;
                s.entry_bytes += len;
            }
        }
        for (p, len) in files_under(&self.dir.join("blobs")) {
            if !is_tmp(&p) {
                s.blobs += 1;
                s.blob_bytes += len;
            }
        }
        s.graphs = self.histories().len();
        s
    }

    /// Removes every entry and blob not referenced by the LAST run of any graph recorded in this
    /// cache, unless it was written less than `keep_days` days ago. Leftover temporary files go
    /// too.
    pub fn gc(&self, keep_days: Option<u64>) -> GcStats {
        let mut keys = BTreeSet::new();
        let mut digests = BTreeSet::new();
        for h in self.histories() {
            if let Some(run) = h.runs.last() {
                for n in run.nodes.values() {
                    keys.insert(n.key.clone());
                    digests.extend(n.outputs.values().cloned());
                }
            }
        }
        // Entries keep their blobs alive.
        for k in &keys {
            if let Ok(Some(e)) = self.read_entry(k) {
                digests.extend(e.outputs.values().map(|o| o.digest.clone()));
            }
        }
        let cutoff =
            keep_days.map(|d| SystemTime::now() - std::time::Duration::from_secs(d * 86_400));
        let young = |p: &Path| {
            cutoff.is_some_and(|c| {
                fs::metadata(p)
                    .and_then(|m| m.modified())
                    .map(|m| m > c)
                    .unwrap_or(false)
            })
        };
        let mut g = GcStats::default();
        for (p, len) in files_under(&self.dir.join("entries")) {
            let key = p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            if (is_tmp(&p) || (!keys.contains(&key) && !young(&p))) && fs::remove_file(&p).is_ok() {
                g.entries_removed += usize::from(!is_tmp(&p));
                g.bytes_freed += len;
            }
        }
        for (p, len) in files_under(&self.dir.join("blobs")) {
            let d = p
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            if (is_tmp(&p) || (!digests.contains(&d) && !young(&p))) && fs::remove_file(&p).is_ok()
            {
                g.blobs_removed += usize::from(!is_tmp(&p));
                g.bytes_freed += len;
            }
        }
        g
    }

    /// Deletes the whole cache folder's content.
    pub fn clear(&self) -> io::Result<()> {
        for sub in ["entries", "blobs", "runs"] {
            let p = self.dir.join(sub);
            if p.exists() {
                fs::remove_dir_all(&p)?;
            }
            fs::create_dir_all(&p)?;
        }
        let memo = self.dir.join("statmemo.json");
        if memo.exists() {
            fs::remove_file(memo)?;
        }
        if let Ok(mut m) = self.memo.lock() {
            m.files.clear();
        }
        Ok(())
    }
}

fn is_tmp(p: &Path) -> bool {
    p.file_name()
        .is_some_and(|n| n.to_string_lossy().ends_with(".tmp"))
}

fn files_under(dir: &Path) -> Vec<(PathBuf, u64)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = fs::read_dir(&d) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            match e.metadata() {
                Ok(m) if m.is_dir() => stack.push(p),
                Ok(m) => out.push((p, m.len())),
                Err(_) => {}
            }
        }
    }
    out.sort();
    out
}

#[cfg(test)]
#[path = "cache_test.rs"]
mod tests;
