"""Reading the world's environment image into NumPy."""

import numpy as np


def find_environment_image(world):
    """The image of the Environment Texture node feeding the world output, or None.

    Walks back from the active World Output's Surface input so that a
    disconnected Environment Texture elsewhere in the tree is ignored; falls
    back to the only Environment Texture node when there is exactly one.
    """
    if world is None or not world.use_nodes or world.node_tree is None:
        return None
    tree = world.node_tree
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    active = [n for n in outputs if getattr(n, "is_active_output", False)] or outputs
    seen, stack = set(), [n for n in active]
    while stack:
        node = stack.pop()
        if node.name in seen:
            continue
        seen.add(node.name)
        if node.type == "TEX_ENVIRONMENT" and node.image is not None:
            return node.image
        for socket in node.inputs:
            stack.extend(link.from_node for link in socket.links)
    candidates = [n for n in tree.nodes if n.type == "TEX_ENVIRONMENT" and n.image is not None]
    return candidates[0].image if len(candidates) == 1 else None


def image_pixels(image) -> np.ndarray:
    """Linear float32 pixels (H, W, 3) of a Blender image, row 0 at the top.

    Blender stores pixels bottom row first as RGBA floats; float images
    (EXR, HDR) are scene-linear already.
    """
    width, height = image.size
    if width == 0 or height == 0:
        raise ValueError(f"image '{image.name}' has no pixels (missing file?)")
    channels = image.channels
    buffer = np.empty(width * height * channels, dtype=np.float32)
    image.pixels.foreach_get(buffer)
    pixels = buffer.reshape(height, width, channels)[::-1]
    if channels >= 3:
        return np.ascontiguousarray(pixels[:, :, :3])
    return np.ascontiguousarray(np.repeat(pixels[:, :, :1], 3, axis=2))
