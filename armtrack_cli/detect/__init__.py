"""Stage: image measurements. The wrist patch by CamShift (Tao & Hu, III-B) and the palm
markers by skin region, Bhattacharyya colour similarity and connected components (Cordella,
III-A). Pure functions of images; the pipeline streams the frames in."""
