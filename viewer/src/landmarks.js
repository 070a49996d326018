// Landmark files: the layouts the server's own reader accepts (pipelines/landmarks_io.py),
// normalised to one list per mesh of vertex ids or [x, y, z] points.

/** keys of the shared-data files whose single id list applies to every mesh */
export const SHARED_LIST_KEYS = ['landmarks_multipie68_0based', 'nearest_vertex_0based'];

export class LandmarkError extends Error {}

/**
 * @param {unknown} data parsed JSON
 * @param {number} nMeshes number of input meshes
 * @returns {Array<Array<number|number[]>>} one list per mesh, same length >= 3
 */
export function parseLandmarks(data, nMeshes) {
  if (data === null || typeof data !== 'object' || Array.isArray(data)) {
    throw new LandmarkError('the landmark file must hold a JSON object');
  }
  let lists;
  if ('landmarks' in data) {
    lists = data.landmarks;
    if (!Array.isArray(lists) || !lists.every(Array.isArray)) {
      throw new LandmarkError('"landmarks" must be a list of lists, one per mesh');
    }
  } else {
    const key = SHARED_LIST_KEYS.find((k) => k in data);
    const faces = Object.keys(data)
      .filter((k) => k.startsWith('face') && data[k] && typeof data[k] === 'object')
      .sort((a, b) => a.length - b.length || (a < b ? -1 : a > b ? 1 : 0));
    if (key !== undefined) {
      if (!Array.isArray(data[key])) throw new LandmarkError(`"${key}" must be a list of vertex ids`);
      lists = Array.from({ length: nMeshes }, () => [...data[key]]);
    } else if (faces.length) {
      lists = faces.map((k) => {
        const d = data[k];
        if (!Array.isArray(d.interior_landmarks_0based)) {
          throw new LandmarkError(`"${k}" lacks interior_landmarks_0based`);
        }
        const ids = [...d.interior_landmarks_0based];
        for (const loop of (d.boundary_landmarks_0based_per_loop || []).slice(1)) ids.push(...loop);
        return ids;
      });
    } else {
      throw new LandmarkError(
        `no "landmarks" key (nor a known layout: ${SHARED_LIST_KEYS.join(', ')}, face1/face2/…)`,
      );
    }
  }
  if (lists.length !== nMeshes) {
    throw new LandmarkError(`the landmark file has ${lists.length} lists but ${nMeshes} meshes were given`);
  }
  const counts = new Set(lists.map((x) => x.length));
  if (counts.size !== 1) {
    throw new LandmarkError(`every mesh needs the same number of landmarks, got ${[...counts].join(', ')}`);
  }
  if (lists[0].length < 3) throw new LandmarkError('at least 3 landmarks per mesh are needed');
  return lists.map((x) => [...x]);
}
