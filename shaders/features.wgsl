// Scene specialisation (src/scene/features.rs): the host sets each override to whether the
// scene uses the feature, so the code for lobes and lights a scene does not have is
// constant-folded away when the pipeline is compiled. The defaults build the general kernel.

override FEATURE_SPECULAR: bool = true;
override FEATURE_TRANSMISSION: bool = true;
override FEATURE_VOLUME: bool = true;
override FEATURE_EMISSIVE_TRIANGLES: bool = true;
override FEATURE_POINT_LIGHTS: bool = true;
override FEATURE_SPOT_LIGHTS: bool = true;
override FEATURE_DIRECTIONAL_LIGHTS: bool = true;
override FEATURE_ENVIRONMENT: bool = true;
override FEATURE_TEXTURES: bool = true;
override FEATURE_NORMAL_MAPS: bool = true;
override FEATURE_ALPHA: bool = true;
override FEATURE_CLEARCOAT: bool = true;
override FEATURE_SHEEN: bool = true;
override FEATURE_DEEP_TREE: bool = true;

// Can the kernel split samples (`frame.splits` > 1)? Off, the split vertex and its
// bookkeeping fold away (src/gpu/context.rs builds one kernel each way on demand).
override SPLITTING: bool = true;
