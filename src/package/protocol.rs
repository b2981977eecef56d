//! The describe protocol: how the packager asks a compiled model (its cdylib's
//! `mbfmu_describe`) for what goes into the FMU, so packaging needs only the binary.
//!
//! Requests and responses are lists of `(key, value)` records, each written as
//! `key byte_length\n` then the value's bytes: values may hold any text (XML, newlines).
//! A `package` answer names the FMU's files: `resource:NAME` under `resources/`, and
//! `file:PATH` at any other path of the archive (version 2: the FMI-LS-REF files).
//! Every response starts with the record `abi` = [`ABI`]; a failure is one `error` record.

/// Bumped whenever a request or a response changes meaning.
pub const ABI: &str = "mbfmu-describe 2";
/// The cdylib's symbol: `char *mbfmu_describe(const char *request)`.
pub const DESCRIBE_SYMBOL: &str = "mbfmu_describe";
/// The cdylib's symbol that frees what `mbfmu_describe` returned (its own allocator).
pub const FREE_SYMBOL: &str = "mbfmu_free";

/// One record list.
pub type Records = Vec<(String, String)>;

/// Writes records in the framing above.
pub fn encode<K: AsRef<str>, V: AsRef<str>>(records: &[(K, V)]) -> String {
    let mut s = String::new();
    for (k, v) in records {
        let (k, v) = (k.as_ref(), v.as_ref());
        debug_assert!(!k.contains([' ', '\n']), "record key {k:?}");
        s.push_str(&format!("{k} {}\n{v}", v.len()));
    }
    s
}

/// Reads records written by [`encode`].
pub fn decode(mut text: &str) -> Result<Records, String> {
    let mut records = Vec::new();
    while !text.is_empty() {
        let (head, rest) = text
            .split_once('\n')
            .ok_or("describe protocol: record header without a newline")?;
        let (key, len) = head
            .split_once(' ')
            .ok_or_else(|| format!("describe protocol: bad record header {head:?}"))?;
        let len: usize = len
            .parse()
            .map_err(|_| format!("describe protocol: bad record length in {head:?}"))?;
        if !rest.is_char_boundary(len.min(rest.len())) || rest.len() < len {
            return Err(format!("describe protocol: record {key} is cut short"));
        }
        records.push((key.to_string(), rest[..len].to_string()));
        text = &rest[len..];
    }
    Ok(records)
}

/// A response's records after its `abi` record, or its error.
pub fn parse_response(text: &str) -> Result<Records, String> {
    let mut records = decode(text)?;
    match records.first() {
        Some((k, v)) if k == "abi" && v == ABI => {}
        Some((k, v)) if k == "abi" => {
            return Err(format!(
                "the model was built against {v}, this mbfmu speaks {ABI}: rebuild it against this mbfmu"
            ))
        }
        _ => return Err("describe protocol: response without an abi record".into()),
    }
    records.remove(0);
    if let Some((_, message)) = records.iter().find(|(k, _)| k == "error") {
        return Err(message.clone());
    }
    Ok(records)
}

/// The value of the first record named `key`.
pub fn value<'a>(records: &'a Records, key: &str) -> Option<&'a str> {
    records
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_with_any_text() {
        let records = vec![
            ("abi".to_string(), ABI.to_string()),
            ("text".to_string(), "a\nb 3\n\n<é>".to_string()),
            ("empty".to_string(), String::new()),
        ];
        assert_eq!(decode(&encode(&records)).unwrap(), records);
        assert_eq!(parse_response(&encode(&records)).unwrap(), records[1..]);
        assert!(decode("text 10\nshort").is_err());
        let failed = encode(&[("abi", ABI), ("error", "no such scene")]);
        assert_eq!(parse_response(&failed).unwrap_err(), "no such scene");
        let old = encode(&[("abi", "mbfmu-describe 0")]);
        assert!(parse_response(&old).unwrap_err().contains("rebuild"));
    }
}
