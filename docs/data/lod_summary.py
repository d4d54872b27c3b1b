#!/usr/bin/env python3
"""Summarises a `lod` capture (docs/techniques.md, "Levels of detail"):
per scene, camera and variant, the triangles drawn of the full count, the
geometry pass's index and vertex bytes, the frame's counted bytes, the
frame time and the image error against LOD off."""
import json
import sys

result = json.load(open(sys.argv[1]))
print("| scene | camera | variant | triangles drawn / full | levels | geometry index+vertex MB | frame MB | frame ms | PSNR vs off (dB) | mean abs |")
print("|---|---|---|---|---|---|---|---|---|---|")
for run in result["runs"]:
    scene = run["scene"] if isinstance(run["scene"], str) else "Sponza"
    if "sponza" in json.dumps(run["scene"]).lower():
        scene = "Sponza"
    indices = next((r["allocation_bytes"] for r in run["resources"]["list"] if r["name"] == "indices"), 0)
    for i, s in enumerate(run["samples"]):
        lod = s.get("extras", {}).get("lod")
        geometry = s["passes"][0]
        geo = sum(x["bytes"] for x in geometry["resources"] if x["name"] in ("indices", "vertices") and x["access"] == "read")
        err = s.get("variant_error") or {}
        psnr = "identical" if err.get("identical") else ("%.2f" % err["psnr"] if err.get("psnr") else "-")
        tri = "%d / %d" % (lod["triangles_drawn"], lod["triangles_full"]) if lod else "full"
        levels = str(lod["levels"]) if lod else "-"
        print("| %s | %d | %s | %s | %s | %.2f | %.2f | %.2f | %s | %s |" % (
            scene, i, run["variant"], tri, levels, geo / 1e6, s["bytes"] / 1e6, s["frame_ms"], psnr,
            "%.3f" % err["mean_abs"] if err else "-"))
    print("| %s | | %s | indices allocation %d bytes | | | | | | |" % (scene, run["variant"], indices))
