# Checks that Blender opens BVH files Kumite writes, and (for a `kumite-motion strike` output)
# that Blender's own forward kinematics puts the effector on the target at the contact frame.
# Not part of the build: Blender is not a project dependency (apt-get install blender).
#
#   kumite-motion strike ... --out strike.bvh --report strike.json
#   blender -b --factory-startup --python scripts/blender-check-bvh.py -- strike.bvh [strike.json] [more.bvh ...]
import builtins
import json
import sys

import bpy

# Debian 12's Blender 3.4 BVH importer opens files with mode 'rU', which Python 3.11 removed.
_open = builtins.open
builtins.open = lambda f, mode="r", *a, **k: _open(f, mode.replace("U", ""), *a, **k)

args = sys.argv[sys.argv.index("--") + 1:]
report = next((json.load(_open(a)) for a in args if a.endswith(".json")), None)
failed = False
for path in (a for a in args if a.endswith(".bvh")):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=path, axis_forward="-Z", axis_up="Y", global_scale=1.0,
                            rotate_mode="NATIVE", use_fps_scale=False, frame_start=1)
    arm = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"][0]
    print(f"IMPORTED {path}: {len(arm.data.bones)} bones")
    if report and report["effector"] in arm.pose.bones:
        bpy.context.scene.frame_set(report["contact_frame"] + 1)  # Blender frames start at 1
        w = arm.matrix_world @ arm.pose.bones[report["effector"]].head
        t = [v / report["bvh_unit_m"] for v in report["target"]]
        tb = (t[0], -t[2], t[1])  # BVH Y-up -> Blender Z-up
        d = sum((a - b) ** 2 for a, b in zip(w, tb)) ** 0.5 * report["bvh_unit_m"]
        print(f"  effector {report['effector']} at contact: {d * 1000:.3f} mm from the target")
        failed |= bool(report["hit"]) and d > 0.001
sys.exit(1 if failed else 0)
