"""Settings saved in the .blend: ``Scene.glossy``."""

import bpy

from ..bake.prefilter import DEFAULT_MAX_SIZE

LAYOUT_ITEMS = [
    ("cube", "Cube", "OpenGL cube strip (N x 6N) in glTF's Y-up frame"),
    ("latlong", "Lat-Long", "Blender's Environment Texture layout (N x 2N)"),
    ("paraboloid", "Dual Paraboloid", "Front +Z, back -Z, extended [-1, 1]^2 domain (N x 2N)"),
    ("sphere", "Sphere Map", "Mirror ball seen from -Y, +Z up (N x N)"),
]

MIP_ITEMS = [
    ("none", "None", "Only the converted map"),
    ("box", "Box 2x2", "Solid-angle-weighted 2x2 box pyramid"),
    ("gauss4", "Gaussian 4x4", "Binomial 4x4 pyramid with cross-face borders"),
    ("gauss6", "Gaussian 6x6", "Binomial 6x6 pyramid with cross-face borders"),
]


class GlossySceneSettings(bpy.types.PropertyGroup):
    export_layout: bpy.props.EnumProperty(
        name="Layout", description="Parameterization of the exported map", items=LAYOUT_ITEMS
    )
    export_size: bpy.props.IntProperty(
        name="Size",
        description="Map size N: cube faces N x N, lat-long N x 2N, paraboloid halves N x N",
        default=256,
        min=2,
        soft_max=2048,
        max=8192,
    )
    export_mip: bpy.props.EnumProperty(
        name="MIP Pyramid", description="Also write a MIP pyramid (cube and lat-long)",
        items=MIP_ITEMS, default="none",
    )
    last_export: bpy.props.StringProperty(
        name="Last Export", description="File written by the last export", subtype="FILE_PATH"
    )
    validate_resolution: bpy.props.IntProperty(
        name="Resolution", description="Longer side of the validation renders (pixels; the "
        "scene's aspect ratio is kept)", default=128, min=16, soft_max=1024, max=4096)
    validate_samples: bpy.props.IntProperty(
        name="Cycles Samples", description="Samples of each of the two Cycles reference renders",
        default=256, min=1, max=65536)
    validate_eevee_samples: bpy.props.IntProperty(
        name="EEVEE Samples", description="EEVEE render samples (native and Glossy)",
        default=16, min=1, max=4096)
    validate_reference: bpy.props.BoolProperty(
        name="NumPy Reference", description="Also shade the objects' pixels with the NumPy "
        "reference over the same probe (what the probe allows: the report's 'Glossy vs "
        "reference' and its diagnosis). Off skips it, most of a narrow lobe's validation "
        "time; objects without a Cycles truth are still measured against it",
        default=True)
    last_report: bpy.props.StringProperty(
        name="Last Report", description="report.md of the last validation", subtype="FILE_PATH")

    @classmethod
    def register(cls):
        bpy.types.Scene.glossy = bpy.props.PointerProperty(type=cls)

    @classmethod
    def unregister(cls):
        del bpy.types.Scene.glossy


class GlossyObjectSettings(bpy.types.PropertyGroup):
    """Probe settings of one object (``Object.glossy``)."""

    probe_size_mode: bpy.props.EnumProperty(
        name="Probe Size", description="How the probe's cube face size is chosen",
        items=[("AUTO", "Auto", "From the narrowest lobe of the object's Glossy materials, "
                                "raised where the world image's small lights need finer "
                                "texels (measured on the image), never finer than the image "
                                "(World Only), at most Probe Resolution"),
               ("FIXED", "Fixed", "Exactly Probe Resolution")],
        default="AUTO",
    )
    probe_resolution: bpy.props.IntProperty(
        name="Probe Resolution",
        description="Cube face size of the captured probe (texels): the size itself (Fixed) "
                    "or its upper bound (Auto)",
        default=256, min=0, soft_min=8, soft_max=1024, max=4096,
    )
    probe_reason: bpy.props.StringProperty(
        name="Probe Size Chosen", description="The face size the last capture used, and why")
    capture_engine: bpy.props.EnumProperty(
        name="Engine", description="Render engine used to capture the probe",
        items=[("CYCLES", "Cycles", "Path-traced capture"),
               ("BLENDER_EEVEE", "EEVEE", "Rasterized capture (faster)")],
    )
    capture_samples: bpy.props.IntProperty(
        name="Samples", description="Render samples per texel, at least: a Cycles capture "
        "raises them on small faces so that a sun smaller than a texel is found, and adaptive "
        "sampling adds up to 2x where a texel is still noisy", default=32, min=1, max=65536,
    )
    clip_start: bpy.props.FloatProperty(name="Clip Start", default=0.01, min=1e-6,
                                        subtype="DISTANCE")
    clip_end: bpy.props.FloatProperty(name="Clip End", default=1000.0, min=1e-3,
                                      subtype="DISTANCE")
    hide_self: bpy.props.BoolProperty(
        name="Hide Self", description="Hide the object while its probe is captured", default=True,
    )
    centre_mode: bpy.props.EnumProperty(
        name="Centre", description="Where the probe is captured",
        items=[("VOLUME", "Volume Centroid", "Centroid of the evaluated mesh's volume"),
               ("BBOX", "Bounding Box", "Centre of the world-space bounding box"),
               ("ORIGIN", "Origin", "The object's origin")],
    )
    probe_source: bpy.props.EnumProperty(
        name="Source", description="Render the scene, or only resample the world's image",
        items=[("RENDER", "Render Scene", "Six 90-degree renders at the centre"),
               ("WORLD", "World Only", "Resample the world's environment image")],
    )
    probe_path: bpy.props.StringProperty(name="Probe File", subtype="FILE_PATH")
    probe_owner: bpy.props.StringProperty(
        name="Probe Owner", description="Name of the object the probe was captured for (a "
        "copy made with Shift+D or Alt+D holds the path but not the probe; ownership.py)")
    probe_stamp: bpy.props.StringProperty(
        name="Probe Stamp", description="Size and time of the probe file as written")
    probe_history: bpy.props.StringProperty(
        name="Probe Files", description="Probe files this object's captures wrote (JSON)")
    probe_centre: bpy.props.FloatVectorProperty(name="Probe Centre", size=3, subtype="XYZ")

    @classmethod
    def register(cls):
        bpy.types.Object.glossy = bpy.props.PointerProperty(type=cls)

    @classmethod
    def unregister(cls):
        del bpy.types.Object.glossy


MODEL_ITEMS = [
    ("MATERIAL", "From Material", "Read the BRDF from the material's own node tree "
     "(Principled, Glossy and Diffuse BSDFs, Mix and Add Shaders): the panel shows the spec "
     "and lists what Glossy ignores"),
    ("ggx", "GGX", "Cycles' GGX (Glossy BSDF, GGX distribution)"),
    ("beckmann", "Beckmann", "Cycles' Beckmann"),
    ("ashikhmin_shirley", "Ashikhmin-Shirley", "Cycles' Ashikhmin-Shirley"),
    ("ward", "Ward", "Ward 1992 (alpha = roughness)"),
    ("phong", "Phong", "Lewis' physically plausible Phong (exponent from roughness)"),
    ("lambert", "Lambert", "Diffuse"),
    ("BUMP", "Bump-Map BRDF", "The BRDF of a surface's micro-structure, computed from its "
     "height field (an image or a preset) after Cabral, Max & Springmeyer"),
    ("CUSTOM", "Custom Spec", "Any bake.brdf spec string"),
]

BUMP_SOURCES = [
    ("IMAGE", "Image File", "A height field image (EXR, or 16-bit PNG): one periodic tile"),
    ("gaussian", "Gaussian", "A Gaussian random surface of the given RMS slope (its BRDF is "
     "close to Beckmann's)"),
    ("noise", "White Noise", "Independent random heights (sand-blasted)"),
    ("grooves", "Grooves", "Parallel cylindrical grooves along the tangent's normal "
     "(brushed): an anisotropic highlight stretched across them"),
]


class GlossyMaterialSettings(bpy.types.PropertyGroup):
    """The BRDF and bake settings of one material (``Material.glossy``)."""

    model: bpy.props.EnumProperty(name="BRDF", items=MODEL_ITEMS, default="MATERIAL")
    roughness: bpy.props.FloatProperty(name="Roughness", default=0.3, min=0.01, max=1.0)
    exponent: bpy.props.FloatProperty(name="Exponent", default=50.0, min=0.0, max=1e5)
    color: bpy.props.FloatVectorProperty(name="Color", subtype="COLOR", size=3, min=0.0,
                                         max=1.0, default=(1.0, 1.0, 1.0))
    diffuse: bpy.props.FloatVectorProperty(
        name="Diffuse", description="Lambertian part, baked as an irradiance map (black: none)",
        subtype="COLOR", size=3, min=0.0, max=1.0, default=(0.0, 0.0, 0.0))
    fresnel_ior: bpy.props.FloatProperty(
        name="Fresnel IOR",
        description="Blend glossy and diffuse by the exact dielectric Fresnel term of this "
                    "index (Heidrich 3.1.1: F glossy + (1 - F) diffuse); 0: plain sum",
        default=0.0, min=0.0, max=10.0)
    spec: bpy.props.StringProperty(name="Spec", description="bake.brdf spec (Custom Spec)",
                                   default="ggx:roughness=0.3")
    method: bpy.props.EnumProperty(
        name="Method", items=[("auto", "Auto", "The Hybrid for an isotropic GGX or Beckmann "
                               "lobe, Runtime Sampling for an anisotropic one, the 3D map "
                               "otherwise (glossy_addon.method_choice; the panel says which "
                               "and why)"),
                              ("3d", "3D Map", "Kautz-McCool 3D map (K slices)"),
                              ("2d", "2D Lobe", "One lobe-filtered map times k(theta_o)"),
                              ("split-sum", "Split Sum", "GGX MIP chain + DFG (GGX only)"),
                              ("runtime", "Runtime Sampling", "Regular sampling of the GGX "
                               "or Beckmann lobe per pixel from pre-blurred probe levels "
                               "(Kurt et al.): anisotropic lobes, exact at grazing views"),
                              ("hybrid", "Hybrid", "3D map and runtime sampling blended per "
                               "pixel by their measured errors (bake.hybrid); runtime "
                               "sampling alone for anisotropic lobes")],
        default="auto")
    anisotropy: bpy.props.FloatProperty(
        name="Anisotropy", description="Cycles' Anisotropy (GGX, Beckmann, Ashikhmin-Shirley): "
        "stretches the lobe along the tangent (> 0) or across it (< 0)",
        default=0.0, min=-1.0, max=1.0)
    rotation: bpy.props.FloatProperty(
        name="Rotation", description="Cycles' Rotation of the anisotropic lobe about the "
        "normal, in turns", default=0.0, min=0.0, max=1.0)
    tangent_type: bpy.props.EnumProperty(
        name="Tangent", description="The anisotropic lobe's tangent, as Cycles' Tangent node "
        "gives it",
        items=[("RADIAL", "Radial", "Around an axis of the object"),
               ("UV_MAP", "UV Map", "Along a UV map's U direction")],
        default="RADIAL")
    tangent_axis: bpy.props.EnumProperty(
        name="Axis", items=[("X", "X", ""), ("Y", "Y", ""), ("Z", "Z", "")], default="Z")
    tangent_uv_map: bpy.props.StringProperty(
        name="UV Map", description="UV map of the tangent (empty: the active render UV map)")
    tangent_note: bpy.props.StringProperty(
        name="Tangent Used", description="Why the last attach used another tangent than set "
        "(empty: as set)")
    samples: bpy.props.IntProperty(
        name="Samples", description="Runtime samples per pixel (the regular pattern with the "
        "closest count). The nodes loop over them: more samples cost shading time per "
        "pixel, not shader compile time", default=19, min=1, max=444, soft_max=200)
    probe_lights: bpy.props.BoolProperty(
        name="Probe Lights", description="Runtime Sampling, Hybrid, and Auto's 3D map of a "
        "From Material texture followed per pixel: take the probe's small "
        "bright lights (a sun, lamps a few texels wide) out of it, and its wide bright "
        "regions (softboxes, windows) as tiles of a quarter of the lobe's width, and shade "
        "them exactly as directional lights (bake.probe_lights; at most 96 per material); "
        "sampling and the map then see the rest",
        default=True)
    runtime_path: bpy.props.StringProperty(
        name="Baked Sampling Levels", description="The runtime-sampling texture of a Hybrid "
        "bake, or the probe lights beside a From Material 3D map's knots (bake.knot_lights)",
        subtype="FILE_PATH")
    slices: bpy.props.IntProperty(name="Slices", default=16, min=0, max=256)
    lobes: bpy.props.IntProperty(name="Lobes", description="Lobes per slice (3D map)",
                                 default=1, min=1, max=4)
    size_mode: bpy.props.EnumProperty(
        name="Map Size Mode", description="How the baked map's size is chosen",
        items=[("AUTO", "Auto", "From the lobe's width and the probe's detail (bake.resolution), "
                                "at most Map Size"),
               ("FIXED", "Fixed", "Exactly Map Size")],
        default="AUTO")
    map_size: bpy.props.IntProperty(
        name="Map Size",
        description="Lat-long rows N (N x 2N): the size itself (Fixed) or its upper bound "
                    "(Auto; bake time grows with its square). Under Auto, Runtime "
                    "Sampling's level stack for a near-mirror lobe (roughness below 0.1), "
                    "its only texture and not filtered, may have twice as many rows (at "
                    "most 1024)",
        default=DEFAULT_MAX_SIZE, min=0, max=1024)
    lamps: bpy.props.BoolProperty(
        name="Lamps", description="Bake separable BRDF factors (Kautz & McCool 1999) so the "
        "attached material responds to the scene's lamps", default=True)
    lamp_parameterization: bpy.props.EnumProperty(
        name="Parameterization", description="The pair of 2D parameters the BRDF is factored "
        "in (bake.separable)",
        items=[("half-difference", "Half / Difference", "Rusinkiewicz's half and difference "
                "vectors: near-specular BRDFs"),
               ("gram-schmidt", "Gram-Schmidt", "Half vector and view in the eq. 4 frame"),
               ("incident-view", "Incident / View", "Light and view directions"),
               ("elevation-azimuth", "Elevation / Azimuth", "(theta_i, theta_o), "
                "(phi_i, phi_o): velvet-like BRDFs")],
        default="half-difference")
    lamp_size: bpy.props.IntProperty(
        name="Factor Size", description="Texels per side of the g factors (the half vector: "
        "narrow lobes need more)", default=256, min=0, max=1024)
    lamp_size_h: bpy.props.IntProperty(
        name="Second Size", description="Texels per side of the h factors (smooth in the "
        "half-vector parameterizations)", default=32, min=0, max=1024)
    lamp_method: bpy.props.EnumProperty(
        name="Method", description="How the BRDF is factored (bake.separable)",
        items=[("sampled", "Sampled Fit", "Weighted least squares from sampled rows and "
                "columns: fine g textures in seconds"),
               ("svd", "Truncated SVD", "The whole matrix (g and h of one size: slow above 64)"),
               ("nd", "Normalized", "The paper's normalized decomposition (whole matrix)")],
        default="sampled")
    lamp_terms: bpy.props.IntProperty(
        name="Terms", description="Pairs of factor textures", default=2, min=0, max=64)
    lamp_path: bpy.props.StringProperty(name="Baked Factors", subtype="FILE_PATH")
    lamp_error: bpy.props.FloatProperty(
        name="Factor Error", description="Cosine-weighted relative RMS error of the factored "
        "BRDF over 8100 stratified pairs (bake.separable.error); -1: none", default=-1.0)
    lamp_set: bpy.props.StringProperty(
        name="Attached Lamps", description="The lamps (names, types) at the last attach (JSON)")
    emission_set: bpy.props.StringProperty(
        name="Attached Emission", description="The emission and alpha inputs the lookup holds, "
        "at the last attach of a From Material lookup (JSON; glossy_addon.emission.values; "
        "empty: no such attach)")
    lamp_skipped: bpy.props.StringProperty(
        name="Skipped Lamps", description="Lamps the last attach could not convert, with the "
        "reason (JSON)")
    chosen_size: bpy.props.IntProperty(name="Baked Size", description="Rows of the last bake")
    size_reason: bpy.props.StringProperty(
        name="Size Reason", description="Why the last bake has the size it has")
    bake_path: bpy.props.StringProperty(name="Baked Map", subtype="FILE_PATH")
    copy_of: bpy.props.StringProperty(
        name="Copy Of", description="The material this one is Glossy's per-object copy of "
        "(a material shared by objects with different probes: each reflects its own)")
    roughness_maps: bpy.props.StringProperty(
        name="Roughness Maps", description="Maps baked at roughness knots for a roughness "
        "texture and/or for a colour or metallic texture (From Material, JSON "
        "[[roughness or null, path, key or null], ...]): combined per pixel")
    diffuse_path: bpy.props.StringProperty(name="Baked Irradiance", subtype="FILE_PATH")
    bake_hash: bpy.props.StringProperty(name="Bake Hash")
    bake_owner: bpy.props.StringProperty(
        name="Bake Owner", description="Name of the material the bake was made for (a copy "
        "of the material holds the path but not the files; ownership.py)")
    bake_probe: bpy.props.StringProperty(
        name="Baked From", description="Probe file the last bake filtered", subtype="FILE_PATH")
    bake_object: bpy.props.StringProperty(
        name="Baked For", description="Object whose probe the last bake filtered")
    bake_stamp: bpy.props.StringProperty(
        name="Bake Stamp", description="Size and time of the baked files as written")
    bake_history: bpy.props.StringProperty(
        name="Baked Files", description="Files this material's bakes wrote (JSON)")
    bake_time: bpy.props.FloatProperty(name="Bake Time")
    bake_inputs: bpy.props.StringProperty(
        name="Baked Inputs", description="The node tree's BRDF inputs at the last bake (From "
        "Material, JSON): the panel names those that changed since")
    validation_error: bpy.props.FloatProperty(
        name="Error vs Cycles", description="Relative RMS (luminance) of EEVEE with Glossy "
        "against Cycles at the last validation", default=-1.0)
    validation_native_error: bpy.props.FloatProperty(
        name="Native Error", description="Relative RMS of EEVEE's own BSDF against Cycles at "
        "the last validation (best of the scene's settings and no sun/clamp); -1: none",
        default=-1.0)
    validation_truth: bpy.props.StringProperty(name="Validated Against")
    validation_date: bpy.props.StringProperty(name="Validated On")
    validation_cause: bpy.props.StringProperty(
        name="Validation Cause", description="Where the last validation's error came from: "
        "bake, probe, noise or mixed (bake.validation.diagnosis); empty without a Cycles truth")
    validation_bake_hash: bpy.props.StringProperty(
        name="Validated Bake", description="Bake hash at the last validation: a re-bake makes "
        "the figures stale")
    bump_source: bpy.props.EnumProperty(name="Height Field", items=BUMP_SOURCES,
                                        default="gaussian")
    bump_file: bpy.props.StringProperty(
        name="Height Image", subtype="FILE_PATH",
        description="EXR or PNG height field, square, one periodic tile of the surface")
    bump_texel: bpy.props.FloatProperty(
        name="Texel Size", subtype="DISTANCE", default=1e-5, min=1e-9, max=1.0, precision=6,
        description="Physical distance between two neighbouring height samples")
    bump_height: bpy.props.FloatProperty(
        name="Height of 1.0", subtype="DISTANCE", default=1e-6, min=1e-12, max=1.0,
        precision=6, description="Physical height of an image value of 1.0 (PNG: full white)")
    bump_size: bpy.props.IntProperty(name="Size", default=256, min=16, max=1024,
                                     description="Texels per side of the preset's tile")
    bump_slope: bpy.props.FloatProperty(name="RMS Slope", default=0.2, min=0.005, max=2.0,
                                        description="RMS slope per axis of the preset surface")
    bump_seed: bpy.props.IntProperty(name="Seed", default=0, min=0)
    bump_period: bpy.props.FloatProperty(name="Period", default=16.0, min=2.0, max=512.0,
                                         description="Texels between grooves")
    bump_depth: bpy.props.FloatProperty(name="Depth", default=4.0, min=0.01, max=256.0,
                                        description="Depth of a groove, texels (<= period/2)")
    bump_ior: bpy.props.FloatProperty(
        name="IOR", default=1.5, min=0.01, max=10.0,
        description="Index of refraction of the facets (the real part for a conductor)")
    bump_k: bpy.props.FloatProperty(
        name="Extinction k", default=0.0, min=0.0, max=20.0,
        description="Imaginary part of a conductor's index (0: a dielectric)")
    bump_isotropic: bpy.props.BoolProperty(
        name="Isotropic", default=True,
        description="Average over azimuths (a 3D table); off keeps the surface's anisotropy "
                    "(a 4D table: validation takes it, the 3D map needs an isotropic BRDF)")
    bump_plot: bpy.props.StringProperty(name="BRDF Plot", subtype="FILE_PATH")
    bump_status: bpy.props.StringProperty(name="Bump BRDF")
    original: bpy.props.PointerProperty(
        type=bpy.types.Material, name="Original Material",
        description="The material as it was before Glossy attached its lookup "
                    "(kept with a fake user; Clear puts it back)")

    def bump_spec(self) -> str:
        """The ``bump:`` spec of the Bump-Map BRDF fields (bake.bumpbrdf.parse_spec)."""
        fresnel = f"ior={self.bump_ior:g},k={self.bump_k:g},isotropic={int(self.bump_isotropic)}"
        if self.bump_source == "IMAGE":
            path = bpy.path.abspath(self.bump_file) if self.bump_file else ""
            scale = self.bump_height / max(self.bump_texel, 1e-12)
            return f"bump:file={path},scale={scale:.6g},{fresnel}"
        shape = (f"period={self.bump_period:g},depth={self.bump_depth:g}"
                 if self.bump_source == "grooves" else
                 f"slope={self.bump_slope:g},seed={self.bump_seed}")
        return f"bump:preset={self.bump_source},size={self.bump_size},{shape},{fresnel}"

    def brdf_spec(self) -> str:
        """The glossy part's bake.brdf spec (From Material: read from the node tree,
        glossy_addon.material_source; raises NodeReadError if the tree has none)."""
        color = "/".join(f"{c:g}" for c in self.color)
        if self.model == "MATERIAL":
            from .material_source import parts

            return parts(self.id_data).glossy_spec
        if self.model == "CUSTOM":
            return self.spec
        if self.model == "BUMP":
            return self.bump_spec()
        if self.model == "ward":
            return f"ward:alpha={self.roughness:g},ks={color}"
        if self.model == "phong":
            return f"phong:n={self.exponent:g},ks={color}"
        if self.model == "lambert":
            return f"lambert:color={color}"
        lobe = ""
        if self.anisotropy != 0.0:
            lobe = f",anisotropy={self.anisotropy:g},rotation={self.rotation:g}"
        return f"{self.model}:roughness={self.roughness:g}{lobe},color={color}"

    def method_used(self) -> str:
        """The method a bake uses: Method, or what Auto chooses for this BRDF
        (glossy_addon.method_choice)."""
        from .method_choice import choose

        return choose(self)[0]

    def diffuse_colour(self) -> tuple:
        """(r, g, b) of the diffuse part baked as irradiance (black: none)."""
        if self.model == "MATERIAL":
            from .material_source import parts

            return parts(self.id_data).diffuse
        return tuple(float(c) for c in self.diffuse)

    def roughness_map_list(self) -> list:
        """[(roughness or None, path, key or None), ...] of the maps a From Material
        lookup combines per pixel (glossy_addon.spatial.map_variants; empty: one
        map)."""
        import json

        def number(value):
            return None if value is None else float(value)

        try:
            return [(number(entry[0]), str(entry[1]),
                     None if len(entry) < 3 or entry[2] is None else str(entry[2]))
                    for entry in json.loads(self.roughness_maps or "[]")]
        except (ValueError, TypeError, IndexError):
            return []

    def tangent(self) -> tuple:
        """("RADIAL", axis) or ("UV_MAP", name): the Tangent node's settings."""
        if self.tangent_type == "UV_MAP":
            return ("UV_MAP", self.tangent_uv_map)
        return ("RADIAL", self.tangent_axis)

    @classmethod
    def register(cls):
        bpy.types.Material.glossy = bpy.props.PointerProperty(type=cls)

    @classmethod
    def unregister(cls):
        del bpy.types.Material.glossy


classes = (GlossySceneSettings, GlossyObjectSettings, GlossyMaterialSettings)
register, unregister = bpy.utils.register_classes_factory(classes)
