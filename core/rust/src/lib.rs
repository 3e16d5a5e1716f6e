//! C ABI over the laz and e57 crates for nhnet's io room (declared in core/src/io/formats_ffi.hpp).
//!
//! Every function returns 0 on success and 1 on failure, with a one-line message written into
//! the caller's `err` buffer (NUL terminated, cut to `err_cap`). Panics inside the crates are
//! caught and reported the same way, never printed: the core never prints. Buffers handed back
//! (`NhBuf`) are owned by Rust and released with `nhnet_buf_free`.

use std::io::Cursor;
use std::os::raw::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Once;

use e57::{
    E57Reader, E57Writer, Extension, Quaternion, Record, RecordDataType,
    RecordName, RecordValue, Transform, Translation,
};
use laz::laszip::ChunkTable;
use laz::{LasZipCompressor, LasZipDecompressor, LazItemType, LazVlr, LazVlrBuilder};

/// A byte buffer owned by Rust.
#[repr(C)]
pub struct NhBuf {
    pub ptr: *mut u8,
    pub len: usize,
    pub cap: usize,
}

fn into_buf(mut v: Vec<u8>) -> NhBuf {
    let buf = NhBuf { ptr: v.as_mut_ptr(), len: v.len(), cap: v.capacity() };
    std::mem::forget(v);
    buf
}

/// Releases a buffer handed back by this library.
///
/// # Safety
/// `buf` must come from this library and be released once.
#[no_mangle]
pub unsafe extern "C" fn nhnet_buf_free(buf: *mut NhBuf) {
    if buf.is_null() || (*buf).ptr.is_null() {
        return;
    }
    drop(Vec::from_raw_parts((*buf).ptr, (*buf).len, (*buf).cap));
    (*buf).ptr = std::ptr::null_mut();
}

static QUIET: Once = Once::new();

/// Runs `f`, turning an Err or a panic into the message in `err`; 0 on success, 1 on failure.
fn guarded(err: *mut c_char, err_cap: usize, f: impl FnOnce() -> Result<(), String>) -> i32 {
    QUIET.call_once(|| std::panic::set_hook(Box::new(|_| {})));
    let msg = match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => return 0,
        Ok(Err(m)) => m,
        Err(_) => "corrupt data (the decoder gave up)".to_string(),
    };
    if !err.is_null() && err_cap > 0 {
        let bytes = msg.as_bytes();
        let n = bytes.len().min(err_cap - 1);
        // SAFETY: the caller hands a writable buffer of err_cap bytes.
        unsafe {
            std::ptr::copy_nonoverlapping(bytes.as_ptr(), err as *mut u8, n);
            *err.add(n) = 0;
        }
    }
    1
}

unsafe fn slice<'a, T>(p: *const T, n: usize) -> &'a [T] {
    if n == 0 || p.is_null() {
        &[]
    } else {
        std::slice::from_raw_parts(p, n)
    }
}

// ---------------------------------------------------------------------------------------------
// LAZ

/// Decompresses the points of a LAZ file held in memory: `vlr` is the payload of the laszip VLR,
/// the compressed data start at `point_offset` of `file`, and `out` (`out_len` bytes, a multiple
/// of the record length) receives the uncompressed records.
///
/// # Safety
/// Pointers must be valid for the given lengths.
#[no_mangle]
pub unsafe extern "C" fn nhnet_laz_decompress(
    file: *const u8,
    file_len: usize,
    vlr: *const u8,
    vlr_len: usize,
    point_offset: u64,
    out: *mut u8,
    out_len: usize,
    err: *mut c_char,
    err_cap: usize,
) -> i32 {
    let file = slice(file, file_len);
    let vlr = slice(vlr, vlr_len);
    let out: &mut [u8] =
        if out_len == 0 { &mut [] } else { std::slice::from_raw_parts_mut(out, out_len) };
    guarded(err, err_cap, || {
        let vlr = LazVlr::from_buffer(vlr).map_err(|e| format!("bad laszip VLR: {e}"))?;
        let size = vlr.items_size() as usize;
        if size == 0 || out.len() % size != 0 {
            return Err(format!("laszip VLR describes {size}-byte points"));
        }
        check_layer_sizes(file, &vlr, point_offset)?;
        let mut cursor = Cursor::new(file);
        cursor.set_position(point_offset);
        let mut dec = LasZipDecompressor::new(cursor, vlr)
            .map_err(|e| format!("bad compressed point data: {e}"))?;
        dec.decompress_many(out).map_err(|e| format!("compressed point data: {e}"))
    })
}

fn u32_at(file: &[u8], pos: u64) -> Option<u64> {
    let p = usize::try_from(pos).ok()?;
    let b = file.get(p..p.checked_add(4)?)?;
    Some(u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
}

/// Layer sizes per chunk of the layered (LAS 1.4, point formats 6-10) compressor; None for the
/// point-wise one.
fn layers_per_chunk(vlr: &LazVlr) -> Option<u64> {
    let mut n = 0;
    for item in vlr.items() {
        n += match item.item_type() {
            LazItemType::Point14 => 9,
            LazItemType::RGB14 | LazItemType::WavePacket14 => 1,
            LazItemType::RGBNIR14 => 2,
            LazItemType::Byte14(count) => u64::from(count),
            _ => return None,
        };
    }
    Some(n)
}

/// The laz crate allocates each chunk's layers at the size the file declares before reading
/// them (and aborts the process when that fails): refuse any layer, and any chunk table, larger
/// than the file itself first.
fn check_layer_sizes(file: &[u8], vlr: &LazVlr, point_offset: u64) -> Result<(), String> {
    let len = file.len() as u64;
    let mut starts = vec![point_offset + 8];
    let i64_at = |pos: u64| {
        file.get(pos as usize..(pos as usize).saturating_add(8))
            .map(|b| i64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]))
            .unwrap_or(-1)
    };
    // As the crate does: the offset before the points, else the last 8 bytes of the file.
    let mut table_at = i64_at(point_offset);
    if table_at <= point_offset as i64 && len >= 8 {
        table_at = i64_at(len - 8);
    }
    if table_at > point_offset as i64 && (table_at as u64) < len {
        let chunks = u32_at(file, table_at as u64 + 4).unwrap_or(0);
        if chunks > len / 4 + 1 {
            return Err(format!("chunk table declares {chunks} chunks, more than the file holds"));
        }
        let mut cursor = Cursor::new(file);
        cursor.set_position(point_offset);
        if let Ok(table) = ChunkTable::read_from(&mut cursor, vlr) {
            let mut at = point_offset + 8;
            for entry in &table {
                at = at.saturating_add(entry.byte_count);
                starts.push(at);
            }
        }
    }
    let Some(layers) = layers_per_chunk(vlr) else { return Ok(()) };
    for start in starts {
        let mut at = start + vlr.items_size() + 4;
        for _ in 0..layers {
            match u32_at(file, at) {
                Some(size) if size > len => {
                    return Err(format!(
                        "a compressed layer of {size} bytes at byte {at}, larger than the file"
                    ))
                }
                Some(_) => at += 4,
                None => break,
            }
        }
    }
    Ok(())
}

/// The laszip VLR payload for point format `format` (0-10) with `extra_bytes` bytes after the
/// standard fields, into `out`.
///
/// # Safety
/// `out` must be writable.
#[no_mangle]
pub unsafe extern "C" fn nhnet_laz_vlr(
    format: u8,
    extra_bytes: u16,
    out: *mut NhBuf,
    err: *mut c_char,
    err_cap: usize,
) -> i32 {
    guarded(err, err_cap, || {
        let vlr = LazVlrBuilder::default()
            .with_point_format(format, extra_bytes)
            .map_err(|e| format!("LAZ cannot hold point format {format}: {e}"))?
            .build();
        let mut bytes = Vec::new();
        vlr.write_to(&mut bytes).map_err(|e| e.to_string())?;
        *out = into_buf(bytes);
        Ok(())
    })
}

/// Compresses `points` (whole records) after `prefix` (the LAS header and VLRs, whose laszip VLR
/// payload is `vlr`); `out` receives prefix + chunk table offset + compressed points + chunk
/// table, the offsets counted from the start of the prefix.
///
/// # Safety
/// Pointers must be valid for the given lengths; `out` must be writable.
#[no_mangle]
pub unsafe extern "C" fn nhnet_laz_compress(
    prefix: *const u8,
    prefix_len: usize,
    vlr: *const u8,
    vlr_len: usize,
    points: *const u8,
    points_len: usize,
    out: *mut NhBuf,
    err: *mut c_char,
    err_cap: usize,
) -> i32 {
    let prefix = slice(prefix, prefix_len);
    let vlr = slice(vlr, vlr_len);
    let points = slice(points, points_len);
    guarded(err, err_cap, || {
        let vlr = LazVlr::from_buffer(vlr).map_err(|e| format!("bad laszip VLR: {e}"))?;
        let mut cursor = Cursor::new(prefix.to_vec());
        cursor.set_position(prefix.len() as u64);
        {
            let mut comp = LasZipCompressor::new(&mut cursor, vlr).map_err(|e| e.to_string())?;
            comp.compress_many(points).map_err(|e| e.to_string())?;
            comp.done().map_err(|e| e.to_string())?;
        }
        *out = into_buf(cursor.into_inner());
        Ok(())
    })
}

// ---------------------------------------------------------------------------------------------
// E57 reading

/// One scan of an E57 file, as read (coordinates in the scan's own frame).
#[derive(Default)]
pub struct Scan {
    name: String,
    pose: Option<Transform>,
    xyz: Vec<f64>,
    intensity: Vec<f32>,
    rgb: Vec<f32>,
    normals: Vec<f32>,
    color_max: f64,
    dropped: u64,
}

/// An E57 file read into memory.
pub struct E57File {
    scans: Vec<Scan>,
}

/// What a scan read and a scan to write have in common (name, pose, coordinates and normals in
/// the scan's own frame); arrays are null when absent. Layout pinned in formats_ffi.hpp.
#[repr(C)]
pub struct NhE57ScanHead {
    pub name: *const u8,
    pub name_len: usize,
    pub has_pose: i32,
    pub quat: [f64; 4], // w x y z
    pub trans: [f64; 3],
    pub n: usize,
    pub xyz: *const f64,
    pub intensity: *const f32,
    pub normals: *const f32,
}

/// View of one scan for C.
#[repr(C)]
pub struct NhE57ScanView {
    pub head: NhE57ScanHead,
    pub rgb: *const f32,
    pub color_max: f64,
    pub dropped: u64,
}

fn find(proto: &[Record], name: &RecordName) -> Option<usize> {
    proto.iter().position(|r| &r.name == name)
}

fn find_ext(proto: &[Record], tag: &str) -> Option<usize> {
    proto.iter().position(|r| matches!(&r.name, RecordName::Unknown { name, .. } if name == tag))
}

fn value(v: &[RecordValue], proto: &[Record], i: usize) -> Result<f64, String> {
    v[i].to_f64(&proto[i].data_type).map_err(|e| e.to_string())
}

fn max_of(dt: &RecordDataType) -> f64 {
    match dt {
        RecordDataType::Integer { max, .. } => *max as f64,
        RecordDataType::ScaledInteger { max, scale, offset, .. } => *max as f64 * scale + offset,
        RecordDataType::Single { max, .. } => max.map(f64::from).unwrap_or(1.0),
        RecordDataType::Double { max, .. } => max.unwrap_or(1.0),
    }
}

fn read_scan<T: std::io::Read + std::io::Seek>(
    reader: &mut E57Reader<T>,
    pc: &e57::PointCloud,
    index: usize,
) -> Result<Scan, String> {
    let p = &pc.prototype;
    let cart = [RecordName::CartesianX, RecordName::CartesianY, RecordName::CartesianZ]
        .map(|n| find(p, &n));
    let sph =
        [RecordName::SphericalRange, RecordName::SphericalAzimuth, RecordName::SphericalElevation]
            .map(|n| find(p, &n));
    let use_cart = cart.iter().all(Option::is_some);
    if !use_cart && !sph.iter().all(Option::is_some) {
        return Err(format!("scan {index} has neither cartesian nor spherical coordinates"));
    }
    let invalid = if use_cart {
        find(p, &RecordName::CartesianInvalidState)
    } else {
        find(p, &RecordName::SphericalInvalidState)
    };
    let intensity = find(p, &RecordName::Intensity);
    let rgb = [RecordName::ColorRed, RecordName::ColorGreen, RecordName::ColorBlue]
        .map(|n| find(p, &n));
    let has_rgb = rgb.iter().all(Option::is_some);
    let nor = ["normalX", "normalY", "normalZ"].map(|n| find_ext(p, n));
    let has_nor = nor.iter().all(Option::is_some);
    let mut scan = Scan {
        name: pc.name.clone().unwrap_or_else(|| format!("scan {index}")),
        pose: pc.transform.clone(),
        ..Default::default()
    };
    if let (true, Some(r)) = (has_rgb, rgb[0]) {
        scan.color_max = max_of(&p[r].data_type);
    }
    let iter = reader.pointcloud_raw(pc).map_err(|e| e.to_string())?;
    for values in iter {
        let v = values.map_err(|e| e.to_string())?;
        if let Some(i) = invalid {
            if v[i].to_i64(&p[i].data_type).map_err(|e| e.to_string())? != 0 {
                scan.dropped += 1;
                continue;
            }
        }
        if use_cart {
            for c in cart.iter().flatten() {
                scan.xyz.push(value(&v, p, *c)?);
            }
        } else {
            let (r, a, e) = (
                value(&v, p, sph[0].unwrap_or(0))?,
                value(&v, p, sph[1].unwrap_or(0))?,
                value(&v, p, sph[2].unwrap_or(0))?,
            );
            scan.xyz.extend([r * e.cos() * a.cos(), r * e.cos() * a.sin(), r * e.sin()]);
        }
        if let Some(i) = intensity {
            scan.intensity.push(value(&v, p, i)? as f32);
        }
        if has_rgb {
            for c in rgb.iter().flatten() {
                scan.rgb.push(value(&v, p, *c)? as f32);
            }
        }
        if has_nor {
            for c in nor.iter().flatten() {
                scan.normals.push(value(&v, p, *c)? as f32);
            }
        }
    }
    Ok(scan)
}

/// Reads every scan of the E57 file held in `data` into `*out` (free with nhnet_e57_free).
///
/// # Safety
/// `data` must be valid for `len` bytes; `out` writable.
#[no_mangle]
pub unsafe extern "C" fn nhnet_e57_read(
    data: *const u8,
    len: usize,
    out: *mut *mut E57File,
    err: *mut c_char,
    err_cap: usize,
) -> i32 {
    let data = slice(data, len);
    guarded(err, err_cap, || {
        let mut reader = E57Reader::new(Cursor::new(data)).map_err(|e| e.to_string())?;
        let mut scans = Vec::new();
        for (i, pc) in reader.pointclouds().iter().enumerate() {
            scans.push(read_scan(&mut reader, pc, i).map_err(|e| format!("scan {i}: {e}"))?);
        }
        *out = Box::into_raw(Box::new(E57File { scans }));
        Ok(())
    })
}

/// Number of scans of a file read by nhnet_e57_read.
///
/// # Safety
/// `file` must come from nhnet_e57_read.
#[no_mangle]
pub unsafe extern "C" fn nhnet_e57_scan_count(file: *const E57File) -> usize {
    (&(*file).scans).len()
}

/// Fills `view` with scan `index` (< nhnet_e57_scan_count); valid until nhnet_e57_free.
///
/// # Safety
/// `file` must come from nhnet_e57_read; `view` writable.
#[no_mangle]
pub unsafe extern "C" fn nhnet_e57_scan(file: *const E57File, index: usize, view: *mut NhE57ScanView) {
    let s = &(&(*file).scans)[index];
    let ptr_or_null = |v: &Vec<f32>| if v.is_empty() { std::ptr::null() } else { v.as_ptr() };
    let (has_pose, quat, trans) = match &s.pose {
        Some(t) => (
            1,
            [t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z],
            [t.translation.x, t.translation.y, t.translation.z],
        ),
        None => (0, [1.0, 0.0, 0.0, 0.0], [0.0; 3]),
    };
    *view = NhE57ScanView {
        head: NhE57ScanHead {
            name: s.name.as_ptr(),
            name_len: s.name.len(),
            has_pose,
            quat,
            trans,
            n: s.xyz.len() / 3,
            xyz: s.xyz.as_ptr(),
            intensity: ptr_or_null(&s.intensity),
            normals: ptr_or_null(&s.normals),
        },
        rgb: ptr_or_null(&s.rgb),
        color_max: s.color_max,
        dropped: s.dropped,
    };
}

/// Releases a file read by nhnet_e57_read.
///
/// # Safety
/// `file` must come from nhnet_e57_read and be released once.
#[no_mangle]
pub unsafe extern "C" fn nhnet_e57_free(file: *mut E57File) {
    if !file.is_null() {
        drop(Box::from_raw(file));
    }
}

// ---------------------------------------------------------------------------------------------
// E57 writing

/// One scan to write.
#[repr(C)]
pub struct NhE57ScanIn {
    pub head: NhE57ScanHead,
    pub rgb: *const u16,
    pub rgb_max: i64,
    /// The normals' confidence (nhnet's `nhnet:confidence` field), or null.
    pub confidence: *const f32,
}

const NOR_NAMESPACE: &str = "nor";
const NOR_URL: &str = "http://www.libe57.org/E57_NOR_surface_normals.txt";
const NHNET_NAMESPACE: &str = "nhnet";
const NHNET_URL: &str = "urn:nhnet:e57:confidence";

fn prototype(s: &NhE57ScanIn) -> Vec<Record> {
    let double = || RecordDataType::Double { min: None, max: None };
    let single = || RecordDataType::Single { min: None, max: None };
    let mut p = vec![
        Record { name: RecordName::CartesianX, data_type: double() },
        Record { name: RecordName::CartesianY, data_type: double() },
        Record { name: RecordName::CartesianZ, data_type: double() },
    ];
    if !s.head.intensity.is_null() {
        p.push(Record { name: RecordName::Intensity, data_type: single() });
    }
    if !s.rgb.is_null() {
        for name in [RecordName::ColorRed, RecordName::ColorGreen, RecordName::ColorBlue] {
            p.push(Record { name, data_type: RecordDataType::Integer { min: 0, max: s.rgb_max } });
        }
    }
    if !s.head.normals.is_null() {
        for tag in ["normalX", "normalY", "normalZ"] {
            let name = RecordName::Unknown {
                namespace: NOR_NAMESPACE.to_string(),
                name: tag.to_string(),
            };
            p.push(Record { name, data_type: single() });
        }
    }
    if !s.confidence.is_null() {
        let name = RecordName::Unknown {
            namespace: NHNET_NAMESPACE.to_string(),
            name: "confidence".to_string(),
        };
        p.push(Record { name, data_type: single() });
    }
    p
}

unsafe fn write_scan<T: std::io::Read + std::io::Write + std::io::Seek>(
    writer: &mut E57Writer<T>,
    s: &NhE57ScanIn,
    index: usize,
) -> Result<(), String> {
    let guid = format!("{{nhnet-scan-{index}}}");
    let mut pc = writer.add_pointcloud(&guid, prototype(s)).map_err(|e| e.to_string())?;
    let h = &s.head;
    let name = String::from_utf8_lossy(slice(h.name, h.name_len)).into_owned();
    pc.set_name(Some(name));
    if h.has_pose != 0 {
        pc.set_transform(Some(Transform {
            rotation: Quaternion { w: h.quat[0], x: h.quat[1], y: h.quat[2], z: h.quat[3] },
            translation: Translation { x: h.trans[0], y: h.trans[1], z: h.trans[2] },
        }));
    }
    let xyz = slice(h.xyz, h.n * 3);
    let intensity = slice(h.intensity, h.n);
    let rgb = slice(s.rgb, h.n * 3);
    let normals = slice(h.normals, h.n * 3);
    let confidence = slice(s.confidence, h.n);
    for i in 0..h.n {
        let mut v: Vec<RecordValue> = xyz[3 * i..3 * i + 3].iter().map(|c| RecordValue::Double(*c)).collect();
        if !intensity.is_empty() {
            v.push(RecordValue::Single(intensity[i]));
        }
        if !rgb.is_empty() {
            v.extend(rgb[3 * i..3 * i + 3].iter().map(|c| RecordValue::Integer(i64::from(*c))));
        }
        if !normals.is_empty() {
            v.extend(normals[3 * i..3 * i + 3].iter().map(|c| RecordValue::Single(*c)));
        }
        if !confidence.is_empty() {
            v.push(RecordValue::Single(confidence[i]));
        }
        pc.add_point(v).map_err(|e| e.to_string())?;
    }
    pc.finalize().map_err(|e| e.to_string())
}

/// Writes `count` scans as one E57 file into `out`.
///
/// # Safety
/// `scans` must hold `count` entries whose arrays are valid for their `n`; `out` writable.
#[no_mangle]
pub unsafe extern "C" fn nhnet_e57_write(
    scans: *const NhE57ScanIn,
    count: usize,
    out: *mut NhBuf,
    err: *mut c_char,
    err_cap: usize,
) -> i32 {
    let scans = slice(scans, count);
    guarded(err, err_cap, || {
        let mut cursor = Cursor::new(Vec::new());
        {
            let mut writer =
                E57Writer::new(&mut cursor, "{nhnet-e57-file}").map_err(|e| e.to_string())?;
            if scans.iter().any(|s| !s.head.normals.is_null()) {
                writer
                    .register_extension(Extension::new(NOR_NAMESPACE, NOR_URL))
                    .map_err(|e| e.to_string())?;
            }
            if scans.iter().any(|s| !s.confidence.is_null()) {
                writer
                    .register_extension(Extension::new(NHNET_NAMESPACE, NHNET_URL))
                    .map_err(|e| e.to_string())?;
            }
            for (i, s) in scans.iter().enumerate() {
                write_scan(&mut writer, s, i)?;
            }
            writer.finalize().map_err(|e| e.to_string())?;
        }
        *out = into_buf(cursor.into_inner());
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    /// (struct, field or "" for its size, Rust's figure) for every struct of the C ABI.
    macro_rules! layout {
        ($($t:ident { $($f:ident),* }),*) => {
            vec![$((stringify!($t), "", size_of::<$t>()),
                   $((stringify!($t), stringify!($f), offset_of!($t, $f)),)*)*]
        };
    }

    /// The `sizeof(S) == N` and `offsetof(S, f) == N` figures of the header's static_asserts.
    fn asserted(header: &str) -> Vec<(String, String, usize)> {
        let mut out = Vec::new();
        for (key, sized) in [("sizeof(", true), ("offsetof(", false)] {
            for (at, _) in header.match_indices(key) {
                let rest = &header[at + key.len()..];
                let close = rest.find(')').expect("closing parenthesis");
                let mut names = rest[..close].split(',').map(str::trim);
                let s = names.next().unwrap().to_string();
                let f = if sized { String::new() } else { names.next().unwrap().to_string() };
                let value = rest[close + 1..].trim_start().strip_prefix("==").expect("== N");
                let digits: String =
                    value.trim_start().chars().take_while(char::is_ascii_digit).collect();
                out.push((s, f, digits.parse().expect("a number")));
            }
        }
        out
    }

    /// The structs' layout is what core/src/io/formats_ffi.hpp pins with static_assert.
    #[test]
    fn c_layout_matches_formats_ffi_hpp() {
        let rust = layout!(
            NhBuf { len, cap },
            NhE57ScanHead { name_len, has_pose, quat, trans, n, xyz, intensity, normals },
            NhE57ScanView { rgb, color_max, dropped },
            NhE57ScanIn { rgb, rgb_max, confidence }
        );
        let header = asserted(include_str!("../../src/io/formats_ffi.hpp"));
        for (s, f, want) in &header {
            let got = rust.iter().find(|(rs, rf, _)| rs == s && rf == f);
            let got = got.unwrap_or_else(|| panic!("the header pins {s}.{f}; add it here")).2;
            assert_eq!(got, *want, "{s}.{f}: Rust {got}, formats_ffi.hpp {want}");
        }
        for (s, f, _) in &rust {
            let pinned = header.iter().any(|(hs, hf, _)| hs == s && hf == f);
            assert!(pinned, "{s}.{f} not pinned in formats_ffi.hpp");
        }
    }
}
