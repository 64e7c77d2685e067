//! The compact recovery-basis file (`recovery.q24`, magic `NLMRCV02`): each column of R in
//! 24-bit fixed point, the mid-edge rows predicted from their edge's end rows, byte-shuffled and
//! zlib-compressed: about 4 times smaller than the Float64 file (`NLMRCV01`) on the default
//! blade (20 MB against 83 MB).
//!
//! Layout (little-endian): magic `NLMRCV02`; rows N_r (u64); columns n (u64); the number p of
//! predicted rows (u64) and the byte length of their table's zlib stream (u64); for each column j
//! its scale s_j (f64) and the byte length b_j (u64) of its zlib stream; then the table's stream
//! (p triples (m, a, b) of u32: row m is predicted from rows a and b, which are not predicted
//! themselves), then the n column streams one after the other.
//!
//! Column j holds the integers k_ij = round(R_ij / s_j), |k_ij| <= 2^23 - 1, with
//! s_j = max_i |R_ij| / (2^23 - 1) (0 for a zero column). Its stream is the zlib compression of
//! the 4 N_r bytes of e_ij as 32-bit two's complement stored by byte plane (all lowest bytes,
//! then the next, ...), where e_ij = k_ij for rows not predicted and
//! e_mj = k_mj - floor((k_aj + k_bj) / 2) for a predicted row m: on a TET10 mesh, the mid-edge
//! node's displacement minus the mean of its edge's two vertices', small for a smooth field, so
//! its high planes compress well. R_ij is read back as k_ij s_j.
//!
//! Accuracy: |R_ij - k_ij s_j| <= s_j / 2 <= 2^-24 max_i |R_ij| (6e-8 of the column's largest
//! entry): the absolute rounding Float32 gives that largest entry; the prediction is exact
//! (integers). R only maps reduced states to mesh displacements for the output (XDMF/VTU fields
//! written in Float32 and pictures), so the file keeps what the output can show; the nonlinear
//! solver never reads it.

use flate2::read::ZlibDecoder;
use flate2::write::ZlibEncoder;
use flate2::Compression;
use rayon::prelude::*;
use std::io::{Read, Write};

/// Magic bytes opening the compact file.
pub const MAGIC: &[u8; 8] = b"NLMRCV02";
/// Largest magnitude of a stored integer, 2^23 - 1.
const LIMIT: f64 = 8_388_607.0;
/// Bytes before the column table: magic, rows, columns, predicted rows, table stream length.
const HEADER: usize = 40;

/// Checks a prediction table for `rows` rows: indices in range, each predicted row once, no
/// row predicted from a predicted row.
pub fn check_predictions(rows: usize, predictions: &[[usize; 3]]) -> Result<(), String> {
    let mut predicted = vec![false; rows];
    for (e, &[m, a, b]) in predictions.iter().enumerate() {
        if m >= rows || a >= rows || b >= rows {
            return Err(format!("prediction {e} ({m}, {a}, {b}): a row >= {rows}"));
        }
        if predicted[m] {
            return Err(format!("prediction {e}: row {m} predicted twice"));
        }
        predicted[m] = true;
    }
    for (e, &[m, a, b]) in predictions.iter().enumerate() {
        if predicted[a] || predicted[b] {
            return Err(format!(
                "prediction {e}: row {m} from rows {a} and {b}, one of them predicted itself"
            ));
        }
    }
    Ok(())
}

/// The file's bytes for the column-major `columns` (each of `rows` finite values), the rows of
/// `predictions` (checked by [`check_predictions`]) stored as their difference to the mean of
/// their two parents.
pub fn encode(rows: usize, columns: &[&[f64]], predictions: &[[usize; 3]]) -> Vec<u8> {
    let encoded: Vec<(f64, Vec<u8>)> = columns
        .par_iter()
        .map(|c| encode_column(c, predictions))
        .collect();
    let table: Vec<u8> = predictions
        .iter()
        .flatten()
        .flat_map(|&i| (i as u32).to_le_bytes())
        .collect();
    let table = zlib(&table);
    let mut out = Vec::with_capacity(
        HEADER
            + table.len()
            + 16 * columns.len()
            + encoded.iter().map(|e| e.1.len()).sum::<usize>(),
    );
    out.extend_from_slice(MAGIC);
    for word in [rows, columns.len(), predictions.len(), table.len()] {
        out.extend_from_slice(&(word as u64).to_le_bytes());
    }
    for (scale, stream) in &encoded {
        out.extend_from_slice(&scale.to_le_bytes());
        out.extend_from_slice(&(stream.len() as u64).to_le_bytes());
    }
    out.extend_from_slice(&table);
    for (_, stream) in &encoded {
        out.extend_from_slice(stream);
    }
    out
}

/// One zlib stream (level 3: within 1 % of level 9 in size here, several times faster).
fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut e = ZlibEncoder::new(Vec::with_capacity(bytes.len() / 2), Compression::new(3));
    // Writing into a Vec cannot fail.
    let _ = e.write_all(bytes);
    e.finish().unwrap_or_default()
}

/// (s_j, zlib stream) of one column.
fn encode_column(column: &[f64], predictions: &[[usize; 3]]) -> (f64, Vec<u8>) {
    let largest = column.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let scale = largest / LIMIT;
    let k: Vec<i64> = if scale > 0.0 {
        column
            .iter()
            .map(|x| (x / scale).round().clamp(-LIMIT, LIMIT) as i64)
            .collect()
    } else {
        vec![0; column.len()]
    };
    let mut e = k.clone();
    for &[m, a, b] in predictions {
        e[m] = k[m] - ((k[a] + k[b]) >> 1);
    }
    let n = column.len();
    let mut planes = vec![0u8; 4 * n];
    for (i, v) in e.iter().enumerate() {
        for (p, byte) in (*v as i32).to_le_bytes().into_iter().enumerate() {
            planes[p * n + i] = byte;
        }
    }
    (scale, zlib(&planes))
}

/// Decodes a whole file: (rows, column-major values), or what is wrong with it.
pub fn decode(bytes: &[u8]) -> Result<(usize, Vec<Vec<f64>>), String> {
    if bytes.len() < HEADER || &bytes[..8] != MAGIC {
        return Err("missing the NLMRCV02 magic bytes: not a compact recovery file".to_string());
    }
    let word = |i: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[i..i + 8]);
        b
    };
    let size = |i: usize| u64::from_le_bytes(word(i));
    let (rows, cols, count, table_len) = (size(8), size(16), size(24), size(32));
    let too_long = || {
        format!(
            "{} bytes cannot hold what the header announces",
            bytes.len()
        )
    };
    let streams_start = cols
        .checked_mul(16)
        .and_then(|t| t.checked_add(HEADER as u64))
        .and_then(|t| t.checked_add(table_len))
        .filter(|&e| e <= bytes.len() as u64)
        .ok_or_else(too_long)? as usize;
    let rows = usize::try_from(rows).map_err(|_| too_long())?;
    let table_start = HEADER + 16 * cols as usize;
    let predictions = decode_table(&bytes[table_start..streams_start], count, rows)?;
    let mut streams = Vec::with_capacity(cols as usize);
    let mut at = streams_start;
    for j in 0..cols as usize {
        let scale = f64::from_le_bytes(word(HEADER + 16 * j));
        let length = size(HEADER + 16 * j + 8);
        let end = (at as u64)
            .checked_add(length)
            .filter(|&e| e <= bytes.len() as u64)
            .ok_or_else(|| format!("column {j}: its stream runs past the {} bytes", bytes.len()))?
            as usize;
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(format!("column {j}: scale {scale} is not finite and >= 0"));
        }
        streams.push((scale, &bytes[at..end]));
        at = end;
    }
    if at != bytes.len() {
        return Err(format!(
            "{} bytes after the last column's stream",
            bytes.len() - at
        ));
    }
    let columns = streams
        .par_iter()
        .enumerate()
        .map(|(j, (scale, stream))| {
            decode_column(rows, *scale, stream, &predictions)
                .map_err(|e| format!("column {j}: {e}"))
        })
        .collect::<Result<Vec<_>, String>>()?;
    Ok((rows, columns))
}

/// The prediction table from its zlib stream, checked.
fn decode_table(stream: &[u8], count: u64, rows: usize) -> Result<Vec<[usize; 3]>, String> {
    let expected = count
        .checked_mul(12)
        .ok_or_else(|| format!("{count} predicted rows"))?;
    let raw = inflate(stream, expected).map_err(|e| format!("prediction table: {e}"))?;
    let predictions: Vec<[usize; 3]> = raw
        .chunks_exact(12)
        .map(|t| {
            let at = |i: usize| u32::from_le_bytes([t[i], t[i + 1], t[i + 2], t[i + 3]]) as usize;
            [at(0), at(4), at(8)]
        })
        .collect();
    check_predictions(rows, &predictions)?;
    Ok(predictions)
}

/// Inflates a zlib stream that must hold exactly `expected` bytes.
fn inflate(stream: &[u8], expected: u64) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(expected.min(1 << 30) as usize);
    ZlibDecoder::new(stream)
        .take(expected + 1)
        .read_to_end(&mut out)
        .map_err(|e| format!("corrupt zlib stream ({e})"))?;
    if out.len() as u64 != expected {
        return Err(format!("{} bytes, expected {expected}", out.len()));
    }
    Ok(out)
}

fn decode_column(
    rows: usize,
    scale: f64,
    stream: &[u8],
    predictions: &[[usize; 3]],
) -> Result<Vec<f64>, String> {
    let planes = inflate(stream, 4 * rows as u64)?;
    let mut k: Vec<i64> = (0..rows)
        .map(|i| {
            i32::from_le_bytes([
                planes[i],
                planes[rows + i],
                planes[2 * rows + i],
                planes[3 * rows + i],
            ]) as i64
        })
        .collect();
    // Parents are never predicted rows (checked), so one pass restores every row.
    for &[m, a, b] in predictions {
        k[m] += (k[a] + k[b]) >> 1;
    }
    Ok(k.into_iter().map(|v| v as f64 * scale).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Round trip within the stated bound 2^-24 max |column|, exact zeros and extremes, and
    /// refusal of damaged files.
    #[test]
    fn round_trip_within_the_fixed_point_bound() {
        let rows = 1000;
        let smooth: Vec<f64> = (0..rows)
            .map(|i| (i as f64 * 0.01).sin() * 3.7e-2)
            .collect();
        let spiky: Vec<f64> = (0..rows)
            .map(|i| if i == 17 { -72.3 } else { 1e-9 * i as f64 })
            .collect();
        let zero = vec![0.0; rows];
        let unit: Vec<f64> = (0..rows).map(|i| if i == 3 { 1.0 } else { 0.0 }).collect();
        let columns: Vec<&[f64]> = vec![&smooth, &spiky, &zero, &unit];
        // Rows 10..20 predicted from rows (i - 10, i + 10) (for the smooth column, the mean of
        // its neighbours 20 rows apart; exact in any case).
        let predictions: Vec<[usize; 3]> = (10..20).map(|i| [i, i - 10, i + 10]).collect();
        check_predictions(rows, &predictions).unwrap();
        let bytes = encode(rows, &columns, &predictions);
        let (r, back) = decode(&bytes).unwrap();
        assert_eq!(r, rows);
        assert_eq!(back.len(), 4);
        for (c, b) in columns.iter().zip(&back) {
            let largest = c.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
            for (x, y) in c.iter().zip(b) {
                // s/2 = largest / (2 (2^23 - 1)), plus the rounding of the product k s.
                assert!(
                    (x - y).abs() <= largest * (0.5 / LIMIT) * (1.0 + 1e-12),
                    "{x} read back as {y}"
                );
            }
        }
        assert!(back[2].iter().all(|&v| v == 0.0));
        assert_eq!(back[3][4], 0.0);
        // Damaged: truncated, trailing bytes, wrong magic, corrupt stream.
        assert!(decode(&bytes[..bytes.len() - 1])
            .unwrap_err()
            .contains("runs past"));
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer).unwrap_err().contains("after the last"));
        assert!(decode(b"NLMRCV01xxxxxxxxxxxxxxxxxxxxxxxx")
            .unwrap_err()
            .contains("magic"));
        let mut corrupt = bytes.clone();
        let last = corrupt.len() - 5;
        corrupt[last] ^= 0xff;
        assert!(decode(&corrupt).is_err());
    }
}
