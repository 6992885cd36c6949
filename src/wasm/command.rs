//! `runCommand(argv, host)`: the shared command line (`gmmcalib calibrate`, `drift`) for the
//! Node command (`packages/gmmcalib/bin/gmmcalib.js`). `host` is a JS object giving files and
//! output; every member forwards to [`Host`]. Returns the exit status.

use js_sys::{Array, Function, Reflect, Uint8Array};
use wasm_bindgen::prelude::*;

use crate::command::{self, EntryKind, Host};
use crate::io::recording::ReadAt;

/// The JS host: `read(path) -> Uint8Array`, `list(dir) -> string[]`, `kind(path) -> 'file' |
/// 'dir' | 'other'`, `write(path, bytes)`, `open(path) -> { size, readAt(offset, length) }`,
/// `out(text)`, `err(text)`, `progress(line)`, `threads`. A failure is thrown with the system's
/// reason as its message.
struct JsHost(JsValue);

/// The message of a thrown value.
fn message(e: JsValue) -> String {
    Reflect::get(&e, &"message".into())
        .ok()
        .and_then(|m| m.as_string())
        .or_else(|| e.as_string())
        .unwrap_or_else(|| format!("{e:?}"))
}

impl JsHost {
    fn call(&self, name: &str, args: &[JsValue]) -> Result<JsValue, String> {
        let f: Function = Reflect::get(&self.0, &name.into())
            .ok()
            .and_then(|f| f.dyn_into().ok())
            .ok_or_else(|| format!("internal: the host has no {name}()"))?;
        f.apply(&self.0, &args.iter().collect::<Array>()).map_err(message)
    }
}

impl Host for JsHost {
    fn read(&mut self, path: &str) -> Result<Vec<u8>, String> {
        Ok(Uint8Array::new(&self.call("read", &[path.into()])?).to_vec())
    }

    fn list(&mut self, dir: &str) -> Result<Vec<String>, String> {
        let names = Array::from(&self.call("list", &[dir.into()])?);
        Ok(names.iter().filter_map(|n| n.as_string()).collect())
    }

    fn kind(&mut self, path: &str) -> EntryKind {
        match self.call("kind", &[path.into()]).ok().and_then(|k| k.as_string()).as_deref() {
            Some("file") => EntryKind::File,
            Some("dir") => EntryKind::Dir,
            _ => EntryKind::Other,
        }
    }

    fn write(&mut self, path: &str, bytes: &[u8]) -> Result<(), String> {
        self.call("write", &[path.into(), Uint8Array::from(bytes).into()]).map(drop)
    }

    fn open(&mut self, path: &str) -> Result<Box<dyn ReadAt>, String> {
        let file = self.call("open", &[path.into()])?;
        let size = Reflect::get(&file, &"size".into()).ok().and_then(|s| s.as_f64());
        let read = Reflect::get(&file, &"readAt".into()).ok().and_then(|f| f.dyn_into().ok());
        match (size, read) {
            (Some(size), Some(read)) => Ok(Box::new(JsFile { size: size as u64, read, file })),
            _ => Err("internal: open() must give { size, readAt }".into()),
        }
    }

    fn out(&mut self, text: &str) {
        let _ = self.call("out", &[text.into()]);
    }

    fn err(&mut self, text: &str) {
        let _ = self.call("err", &[text.into()]);
    }

    fn progress(&mut self, line: &str) {
        let _ = self.call("progress", &[line.into()]);
    }

    fn threads(&self) -> usize {
        // wasm32 runs on one thread (crate::threads_here); the number is only passed on.
        1
    }
}

/// A recording opened by the host: `readAt(offset, length) -> Uint8Array`.
struct JsFile {
    size: u64,
    read: Function,
    file: JsValue,
}

impl ReadAt for JsFile {
    fn size(&self) -> u64 {
        self.size
    }

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        let bytes = self
            .read
            .call2(&self.file, &(offset as f64).into(), &(buf.len() as f64).into())
            .map_err(|e| std::io::Error::other(message(e)))?;
        let bytes = Uint8Array::new(&bytes);
        if bytes.length() as usize != buf.len() {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        bytes.copy_to(buf);
        Ok(())
    }
}

/// Runs `gmmcalib ARGV...` (without the program's name) over `host`; the exit status.
#[wasm_bindgen(js_name = runCommand)]
pub fn run_command(argv: Vec<String>, host: JsValue) -> u8 {
    command::run(&argv, &mut JsHost(host))
}
