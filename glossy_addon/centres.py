"""Where an object's probe is captured: volume centroid, bounding-box centre or origin."""

import numpy as np


def world_triangles(obj, depsgraph):
    """World-space vertices (N, 3) and triangles (M, 3) of the evaluated mesh."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        count = len(mesh.vertices)
        coordinates = np.empty(count * 3, dtype=np.float64)
        mesh.vertices.foreach_get("co", coordinates)
        triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
        mesh.loop_triangles.foreach_get("vertices", triangles)
    finally:
        evaluated.to_mesh_clear()
    matrix = np.array(obj.matrix_world)
    local = coordinates.reshape(-1, 3)
    world = local @ matrix[:3, :3].T + matrix[:3, 3]
    return world, triangles.reshape(-1, 3)


def volume_centroid(vertices, triangles):
    """Centroid (3,) of the solid bounded by a closed triangle mesh, and its volume.

    Divergence theorem: each triangle with the origin spans a signed
    tetrahedron of volume det(v0, v1, v2) / 6 and centroid (v0 + v1 + v2) / 4.
    Returns (None, 0.0) when the mesh encloses no volume (open or flat).
    """
    v0, v1, v2 = (vertices[triangles[:, i]] for i in range(3))
    # Relative to a point on the mesh, for precision far from the origin.
    anchor = vertices.mean(axis=0)
    v0, v1, v2 = v0 - anchor, v1 - anchor, v2 - anchor
    signed = np.einsum("ij,ij->i", v0, np.cross(v1, v2)) / 6.0
    volume = float(signed.sum())
    extent = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    if abs(volume) <= 1e-9 * max(extent, 1e-12) ** 3:
        return None, 0.0
    centroid = (signed[:, None] * (v0 + v1 + v2)).sum(axis=0) / (4.0 * volume)
    return centroid + anchor, abs(volume)


def probe_centre(obj, mode, depsgraph):
    """World-space probe centre (3,) for ``mode`` VOLUME, BBOX or ORIGIN.

    VOLUME falls back to the bounding-box centre for meshes that enclose no
    volume (a plane, an open surface); returns (centre, mode actually used).
    """
    if mode == "ORIGIN":
        return np.array(obj.matrix_world.translation), "ORIGIN"
    vertices, triangles = world_triangles(obj, depsgraph)
    if len(vertices) == 0:
        return np.array(obj.matrix_world.translation), "ORIGIN"
    if mode == "VOLUME" and len(triangles):
        centroid, _ = volume_centroid(vertices, triangles)
        if centroid is not None:
            return centroid, "VOLUME"
    return 0.5 * (vertices.min(axis=0) + vertices.max(axis=0)), "BBOX"
