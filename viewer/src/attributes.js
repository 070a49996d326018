// Vertex attributes as plain floats, whatever their storage (no DOM: tests run it in Node).

/** An attribute's values as floats, flat (normalized integers decoded, interleaved views
 * gathered: a compressed GLB's targets are KHR_mesh_quantization shorts in 8-byte rows). */
export function floatValues(attr) {
  if (!attr.isInterleavedBufferAttribute && !attr.normalized && attr.array instanceof Float32Array) return attr.array;
  const k = attr.itemSize;
  const out = new Float32Array(attr.count * k);
  for (let i = 0; i < attr.count; i++) for (let c = 0; c < k; c++) out[i * k + c] = attr.getComponent(i, c);
  return out;
}
