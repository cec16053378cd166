// Reads a LAS file with loaders.gl (an independent reader) and prints, as JSON, its header and
// the positions of the points at the given indices: node read_las.mjs FILE [INDEX...]
import {readFileSync} from 'node:fs';
import {parse} from '@loaders.gl/core';
import {LAZRsLoader} from '@loaders.gl/las';
import {createRequire} from 'node:module';
import {dirname, join} from 'node:path';
import {pathToFileURL} from 'node:url';

// The loader fetches its WebAssembly by URL, which Node's fetch cannot do for files: hand the
// same module its bytes first (it keeps them, and the loader then finds it initialised).
const lasDir = dirname(createRequire(import.meta.url).resolve('@loaders.gl/las'));
const wasmDir = join(lasDir, 'libs', 'laz-rs-wasm');
const {default: initWasm} = await import(pathToFileURL(join(wasmDir, 'laz_rs_wasm.js')).href);
await initWasm({module_or_path: readFileSync(join(wasmDir, 'laz_rs_wasm_bg.wasm'))});

const [file, ...indices] = process.argv.slice(2);
const bytes = readFileSync(file);
const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const data = await parse(buffer, LAZRsLoader, {worker: false, las: {fp64: true, shape: 'mesh'}});
const pos = data.attributes.POSITION.value;
const intensity = data.attributes.intensity ? data.attributes.intensity.value : null;
const color = data.attributes.COLOR_0 || null;
const points = indices.map(Number).map((i) => ({
  index: i,
  position: [pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]],
  intensity: intensity ? intensity[i] : null,
  color: color ? Array.from(color.value.slice(color.size * i, color.size * i + 3)) : null,
}));
console.log(JSON.stringify({
  header: data.loaderData,
  vertexCount: data.header.vertexCount,
  count: pos.length / 3,
  points,
}, (k, v) => (typeof v === 'bigint' ? Number(v) : v)));
