// MikkTSpace tangents of unwelded triangles (npm mikktspace, the WebAssembly build of the reference code).
// stdin: uint32 corner count N, then N*3 float32 positions, N*3 float32 normals, N*2 float32 texture coordinates
// (little-endian); stdout: N*4 float32 tangents (xyz, w the bitangent's sign, in MikkTSpace's own convention).
const { generateTangents } = require("mikktspace");

const chunks = [];
process.stdin.on("data", (c) => chunks.push(c));
process.stdin.on("end", () => {
  const data = Buffer.concat(chunks);
  const n = data.readUInt32LE(0);
  const floats = new Float32Array(data.buffer.slice(data.byteOffset + 4, data.byteOffset + 4 + n * 8 * 4));
  const tangents = generateTangents(floats.subarray(0, n * 3), floats.subarray(n * 3, n * 6),
                                    floats.subarray(n * 6, n * 8));
  process.stdout.write(Buffer.from(tangents.buffer, tangents.byteOffset, tangents.byteLength));
});
