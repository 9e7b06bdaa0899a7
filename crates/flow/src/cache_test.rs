//! Unit tests of `cache.rs`.

use super::*;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "crestflow-cache-test-{name}-{}",
        std::process::id()
    ));
    let _ = fs::remove_dir_all(&d);
    d
}

#[test]
fn blobs_are_verified_and_entries_round_trip() {
    let d = tmpdir("blobs");
    let c = CacheStore::open(&d).unwrap();
    let bytes = b"hello".to_vec();
    let digest = blake3::hash(&bytes).to_hex().to_string();
    c.write_blob(&digest, &bytes).unwrap();
    assert_eq!(c.read_blob(&digest).unwrap(), bytes);
    fs::write(c.blob_path(&digest), b"hellO").unwrap();
    assert!(c.read_blob(&digest).unwrap_err().contains("corrupt"));
    let e = Entry {
        kind: "k".into(),
        version: 1,
        outputs: BTreeMap::new(),
        output_files: vec![],
    };
    c.write_entry("abc", &e).unwrap();
    assert_eq!(c.read_entry("abc").unwrap(), Some(e));
    assert_eq!(c.read_entry("nope").unwrap(), None);
    fs::write(c.entry_path("abc"), b"{not json").unwrap();
    assert!(c.read_entry("abc").unwrap_err().contains("corrupt"));
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn hex_round_trip() {
    let b = [0u8, 1, 127, 128, 255];
    assert_eq!(to_hex(&b), "00017f80ff");
    assert_eq!(from_hex("00017F80ff").unwrap(), b);
    assert_eq!(from_hex("0g"), None);
    assert_eq!(from_hex("abc"), None);
}

#[test]
fn stat_memo_notices_changes() {
    let d = tmpdir("memo");
    let c = CacheStore::open(&d).unwrap();
    let f = d.join("input.txt");
    fs::write(&f, b"one").unwrap();
    let h1 = c.file_hash(&f).unwrap();
    assert_eq!(h1, blake3::hash(b"one").to_hex().to_string());
    fs::write(&f, b"two!").unwrap();
    let h2 = c.file_hash(&f).unwrap();
    assert_eq!(h2, blake3::hash(b"two!").to_hex().to_string());
    let _ = fs::remove_dir_all(&d);
}

/// Input files are hashed only when they are regular files: a pipe or a device such as
/// `/dev/zero` would never end (`/dev/null` stands in for them; it would hash as empty).
#[test]
fn only_regular_files_are_hashed() {
    let d = tmpdir("hash-kinds");
    fs::create_dir_all(&d).unwrap();
    let err = hash_file(&d).unwrap_err();
    assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
    #[cfg(unix)]
    {
        let link = d.join("device.off");
        std::os::unix::fs::symlink("/dev/null", &link).unwrap();
        let err = hash_file(&link).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidInput, "{err}");
        let store = CacheStore::open(&d.join("cache")).unwrap();
        assert!(store.file_hash(&link).is_err());
    }
    let f = d.join("a.txt");
    fs::write(&f, b"abc").unwrap();
    assert_eq!(
        hash_file(&f).unwrap(),
        blake3::hash(b"abc").to_hex().to_string()
    );
    let _ = fs::remove_dir_all(&d);
}
