"""The glTF reading both peer converters share (`mitsuba_peer.py`, `pbrt_peer.py`): written
independently of pathlight's loader, so that a loader bug shows up as a failed z-test rather
than being copied into both renders. Only what the benchmark scenes use: triangle lists,
node transforms, vertex normals, perspective cameras, and the materials both peers model as
pathlight does ([`peer_material`]); anything else is a SceneError.
"""

import base64
import json
import os
import struct

import numpy as np


class SceneError(Exception):
    pass


# ---------------------------------------------------------------------------------------
# glTF reading


def read_gltf(path):
    """(json, [buffer bytes]) of a .gltf or .glb."""
    with open(path, "rb") as f:
        data = f.read()
    bin_chunk = None
    if data[:4] == b"glTF":
        _, _, length = struct.unpack_from("<III", data, 0)
        offset = 12
        doc = None
        while offset < length:
            chunk_length, chunk_type = struct.unpack_from("<II", data, offset)
            chunk = data[offset + 8 : offset + 8 + chunk_length]
            if chunk_type == 0x4E4F534A:
                doc = json.loads(chunk.decode("utf-8"))
            elif chunk_type == 0x004E4942:
                bin_chunk = chunk
            offset += 8 + chunk_length
        if doc is None:
            raise SceneError(f"{path}: a GLB without a JSON chunk")
    else:
        doc = json.loads(data.decode("utf-8"))
    buffers = []
    for i, b in enumerate(doc.get("buffers", [])):
        uri = b.get("uri")
        if uri is None:
            if bin_chunk is None:
                raise SceneError(f"{path}: buffer {i} has no uri and there is no GLB binary chunk")
            buffers.append(bin_chunk)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            with open(os.path.join(os.path.dirname(path), uri), "rb") as f:
                buffers.append(f.read())
    return doc, buffers


COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}


def read_accessor(doc, buffers, index):
    a = doc["accessors"][index]
    if "sparse" in a:
        raise SceneError(f"accessor {index}: sparse accessors are not converted")
    n = COMPONENTS[a["type"]]
    dtype = np.dtype(DTYPES[a["componentType"]])
    view = doc["bufferViews"][a["bufferView"]]
    buf = buffers[view["buffer"]]
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    stride = view.get("byteStride", n * dtype.itemsize)
    count = a["count"]
    raw = np.frombuffer(buf, dtype=np.uint8, count=(count - 1) * stride + n * dtype.itemsize, offset=start)
    rows = np.lib.stride_tricks.as_strided(raw, shape=(count, n * dtype.itemsize), strides=(stride, 1))
    return np.ascontiguousarray(rows).view(dtype).reshape(count, n)


def node_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    t = np.array(node.get("translation", [0, 0, 0]), dtype=np.float64)
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = np.array(node.get("scale", [1, 1, 1]), dtype=np.float64)
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    m = np.eye(4)
    m[:3, :3] = r * s
    m[:3, 3] = t
    return m


def walk(doc):
    """(node, world matrix) for every node of the default scene."""
    scene = doc["scenes"][doc.get("scene", 0)]
    stack = [(n, np.eye(4)) for n in scene["nodes"]]
    while stack:
        index, parent = stack.pop()
        node = doc["nodes"][index]
        world = parent @ node_matrix(node)
        yield node, world
        stack.extend((c, world) for c in node.get("children", []))


def find_camera(doc):
    for node, world in walk(doc):
        if "camera" in node:
            camera = doc["cameras"][node["camera"]]
            if camera.get("type") != "perspective":
                raise SceneError("only perspective cameras are converted")
            return camera["perspective"], world
    raise SceneError("the scene has no camera")



def triangle_meshes(doc, buffers, transform):
    """(name, world positions, world unit normals or None, faces, material dict) for every
    triangle primitive of the default scene, placed by `transform` (4x4) after its node's
    world matrix, faces wound counter-clockwise seen from the front after any mirroring."""
    for node, world in walk(doc):
        if "mesh" not in node:
            continue
        world = transform @ world
        linear = world[:3, :3]
        normal_matrix = np.linalg.inv(linear).T
        flip = np.linalg.det(linear) < 0  # glTF: a mirroring transform reverses the winding
        for p, prim in enumerate(doc["meshes"][node["mesh"]]["primitives"]):
            if prim.get("mode", 4) != 4:
                raise SceneError(f"mesh {node['mesh']}: only triangle lists are converted")
            positions = read_accessor(doc, buffers, prim["attributes"]["POSITION"]).astype(np.float64)
            positions = positions @ linear.T + world[:3, 3]
            normals = None
            if "NORMAL" in prim["attributes"]:
                normals = read_accessor(doc, buffers, prim["attributes"]["NORMAL"]).astype(np.float64) @ normal_matrix.T
                normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)
            if "indices" in prim:
                faces = read_accessor(doc, buffers, prim["indices"]).reshape(-1, 3).astype(np.int64)
            else:
                faces = np.arange(len(positions)).reshape(-1, 3)
            if flip:
                faces = faces[:, ::-1]
            material = doc["materials"][prim["material"]] if "material" in prim else {}
            yield f"{node['mesh']}-{p}", positions, normals, faces, material


def camera_frame(doc):
    """(glTF perspective camera dict, eye, forward, up) of the first camera node."""
    perspective, world = find_camera(doc)
    eye = world[:3, 3]
    forward = world[:3, :3] @ np.array([0.0, 0.0, -1.0])
    up = world[:3, :3] @ np.array([0.0, 1.0, 0.0])
    return perspective, eye, forward, up


def peer_material(material):
    """The model of a glTF material that a peer renders exactly as pathlight does, as
    (kind, parameter, emitted RGB or None): ("lambertian", base RGB) for metallic 0,
    roughness 1, KHR_materials_specular factor 0; ("mirror", None) for smooth metal of base
    colour 1 (reflectance 1: pathlight's Schlick Fresnel with F0 = 1 is 1 too);
    ("glass", index) for smooth, clear, solid glass (transmission 1, KHR_materials_volume,
    no attenuation). Anything else is a SceneError, not an approximation."""
    name = material.get("name", "(unnamed)")
    pbr = material.get("pbrMetallicRoughness", {})
    ext = material.get("extensions", {})
    base = pbr.get("baseColorFactor", [1, 1, 1, 1])[:3]
    metallic = pbr.get("metallicFactor", 1.0)
    roughness = pbr.get("roughnessFactor", 1.0)
    if "baseColorTexture" in pbr or "metallicRoughnessTexture" in pbr or "normalTexture" in material:
        raise SceneError(f"material '{name}': textures are not converted")
    emissive = np.array(material.get("emissiveFactor", [0, 0, 0]), dtype=np.float64)
    emissive = emissive * ext.get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
    emission = emissive.tolist() if emissive.max() > 0 else None
    transmission = ext.get("KHR_materials_transmission", {}).get("transmissionFactor", 0.0)
    specular = ext.get("KHR_materials_specular", {}).get("specularFactor", 1.0)
    ior = ext.get("KHR_materials_ior", {}).get("ior", 1.5)
    if transmission == 1.0 and roughness == 0.0 and metallic == 0.0:
        volume = ext.get("KHR_materials_volume")
        if volume is None or volume.get("thicknessFactor", 0.0) <= 0.0:
            raise SceneError(f"material '{name}': thin-walled glass is not converted")
        if "attenuationDistance" in volume:
            raise SceneError(f"material '{name}': volume attenuation is not converted")
        return "glass", ior, emission
    if transmission != 0.0:
        raise SceneError(f"material '{name}': only smooth, clear, solid glass is converted")
    if metallic == 1.0 and roughness == 0.0 and base == [1.0, 1.0, 1.0]:
        return "mirror", None, emission
    if metallic == 0.0 and roughness == 1.0 and specular == 0.0:
        return "lambertian", base, emission
    raise SceneError(
        f"material '{name}' (metallic {metallic}, roughness {roughness}, specular {specular}): "
        "no peer model is the same as pathlight's; not converted"
    )
