-- Renderer variants (docs/result-schema.md, "Variants"): a run's canonical
-- renderer options and its label, a sample's technique measurements and its
-- image error against the variant's reference variant. Applied after
-- 0002_sweeps in one transaction, which then sets PRAGMA user_version = 3.
-- Never edit a released migration.

-- The run's canonical "options" ({} for the renderer as it is) and "variant"
-- label ("forward output=overdraw"); runs stored before are their renderer.
ALTER TABLE runs ADD COLUMN options TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(options));
ALTER TABLE runs ADD COLUMN variant TEXT;
UPDATE runs SET variant = renderer WHERE variant IS NULL;
-- Filters end in id, as for the other run filters (0001_initial).
CREATE INDEX runs_by_variant ON runs (variant, id);

-- The sample's "extras" object, and its "variant_error" stored as image_error
-- is: variant_against is NULL when the sample was not compared with a
-- reference variant; variant_psnr is NULL when the images are identical.
ALTER TABLE samples ADD COLUMN extras TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(extras));
ALTER TABLE samples ADD COLUMN variant_against TEXT;
ALTER TABLE samples ADD COLUMN variant_identical INTEGER;
ALTER TABLE samples ADD COLUMN variant_psnr REAL;
ALTER TABLE samples ADD COLUMN variant_max_abs REAL;
ALTER TABLE samples ADD COLUMN variant_mean_abs REAL;
