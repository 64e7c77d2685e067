//! The compact recovery-basis file (`recovery.q24`, magic `NLMRCV02`): each column of R in
//! 24-bit fixed point, byte-shuffled and zlib-compressed, about 3.3 times smaller than the
//! Float64 file (`NLMRCV01`) on the default blade (25 MB against 83 MB).
//!
//! Layout (little-endian): magic `NLMRCV02`; rows N_r (u64); columns n (u64); for each column j
//! its scale s_j (f64) and the byte length b_j (u64) of its zlib stream; then the n streams one
//! after the other. Column j holds the integers k_ij = round(R_ij / s_j), |k_ij| <= 2^23 - 1,
//! with s_j = max_i |R_ij| / (2^23 - 1) (0 for a zero column); its stream is the zlib
//! compression of the 3 N_r bytes of the k_ij as 24-bit two's complement, stored by byte plane
//! (all low bytes, then all middle bytes, then all high bytes: the high planes of a smooth
//! field compress well). R_ij is read back as k_ij s_j.
//!
//! Accuracy: |R_ij - k_ij s_j| <= s_j / 2 <= 2^-24 max_i |R_ij| (6e-8 of the column's largest
//! entry): the absolute rounding Float32 gives that largest entry. R only maps reduced states to
//! mesh displacements for the output (VTU/XDMF fields written in Float32 and pictures), so the
//! file keeps what the output can show; the nonlinear solver never reads it.

use flate2::read::ZlibDecoder;
use flate2::write::ZlibEncoder;
use flate2::Compression;
use rayon::prelude::*;
use std::io::{Read, Write};

/// Magic bytes opening the compact file.
pub const MAGIC: &[u8; 8] = b"NLMRCV02";
/// Largest magnitude of a stored integer, 2^23 - 1.
const LIMIT: f64 = 8_388_607.0;
/// Bytes before the column table: magic, rows, columns.
const HEADER: usize = 24;

/// The file's bytes for the column-major `columns` (each of `rows` finite values).
pub fn encode(rows: usize, columns: &[&[f64]]) -> Vec<u8> {
    let encoded: Vec<(f64, Vec<u8>)> = columns.par_iter().map(|c| encode_column(c)).collect();
    let mut out = Vec::with_capacity(
        HEADER + 16 * columns.len() + encoded.iter().map(|e| e.1.len()).sum::<usize>(),
    );
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(rows as u64).to_le_bytes());
    out.extend_from_slice(&(columns.len() as u64).to_le_bytes());
    for (scale, stream) in &encoded {
        out.extend_from_slice(&scale.to_le_bytes());
        out.extend_from_slice(&(stream.len() as u64).to_le_bytes());
    }
    for (_, stream) in &encoded {
        out.extend_from_slice(stream);
    }
    out
}

/// (s_j, zlib stream) of one column.
fn encode_column(column: &[f64]) -> (f64, Vec<u8>) {
    let largest = column.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let scale = largest / LIMIT;
    let n = column.len();
    let mut planes = vec![0u8; 3 * n];
    if scale > 0.0 {
        for (i, x) in column.iter().enumerate() {
            let k = (x / scale).round().clamp(-LIMIT, LIMIT) as i32;
            let b = k.to_le_bytes();
            planes[i] = b[0];
            planes[n + i] = b[1];
            planes[2 * n + i] = b[2];
        }
    }
    // Level 3: within 1 % of level 9 in size here, several times faster.
    let mut e = ZlibEncoder::new(Vec::with_capacity(3 * n / 2), Compression::new(3));
    // Writing into a Vec cannot fail.
    let _ = e.write_all(&planes);
    (scale, e.finish().unwrap_or_default())
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
    let rows = u64::from_le_bytes(word(8));
    let cols = u64::from_le_bytes(word(16));
    let table_end = cols
        .checked_mul(16)
        .and_then(|t| t.checked_add(HEADER as u64))
        .filter(|&e| e <= bytes.len() as u64)
        .ok_or_else(|| {
            format!(
                "{} bytes cannot hold the table of {cols} columns",
                bytes.len()
            )
        })? as usize;
    let (rows, cols) = (rows as usize, cols as usize);
    let mut streams = Vec::with_capacity(cols);
    let mut at = table_end;
    for j in 0..cols {
        let scale = f64::from_le_bytes(word(HEADER + 16 * j));
        let length = u64::from_le_bytes(word(HEADER + 16 * j + 8));
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
            decode_column(rows, *scale, stream).map_err(|e| format!("column {j}: {e}"))
        })
        .collect::<Result<Vec<_>, String>>()?;
    Ok((rows, columns))
}

fn decode_column(rows: usize, scale: f64, stream: &[u8]) -> Result<Vec<f64>, String> {
    let mut planes = Vec::with_capacity(3 * rows);
    ZlibDecoder::new(stream)
        .take(3 * rows as u64 + 1)
        .read_to_end(&mut planes)
        .map_err(|e| format!("corrupt zlib stream ({e})"))?;
    if planes.len() != 3 * rows {
        return Err(format!(
            "{} bytes of values, expected 3 x {rows} rows",
            planes.len()
        ));
    }
    Ok((0..rows)
        .map(|i| {
            let b = [planes[i], planes[rows + i], planes[2 * rows + i]];
            // Sign-extend the 24-bit integer.
            let k = i32::from_le_bytes([b[0], b[1], b[2], if b[2] & 0x80 != 0 { 0xff } else { 0 }]);
            k as f64 * scale
        })
        .collect())
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
        let bytes = encode(rows, &columns);
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
