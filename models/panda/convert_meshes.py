"""Convert the Panda's collision meshes from STL (as franka_description ships them) to OBJ.

Drake's SceneGraph takes OBJ (not STL) for a mesh's convex hull, so the URDF names the
OBJ files; the STL files are kept beside them as received. Run from anywhere:
``python models/panda/convert_meshes.py``. The conversion keeps every vertex (trimesh
merges duplicate vertices of the STL's separate triangles; the shape is the same).
"""

from pathlib import Path

import trimesh

MESHES = Path(__file__).resolve().parent / "meshes" / "collision"

if __name__ == "__main__":
    for stl in sorted(MESHES.glob("*.stl")):
        mesh = trimesh.load(str(stl), force="mesh")
        obj = stl.with_suffix(".obj")
        obj.write_text(trimesh.exchange.obj.export_obj(mesh, include_normals=False,
                                                      include_texture=False, header=None))
        print(f"wrote {obj} ({len(mesh.vertices)} vertices, {len(mesh.faces)} faces)")
