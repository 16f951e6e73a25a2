#pragma once
// Merging view databases: shards built separately (one per model, on several machines: `silpose
// build-db` per model, then `silpose merge-db`) become one database, byte for byte the file that
// `silpose build-db` of all their models at once writes, the models in the order of the shards.

#include <filesystem>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"

namespace silpose {

/// The first generation parameter in which `a` and `b` differ, as "VIEWS: 1000 vs 500" (names as
/// in `silpose build-db --help`), or "" if they are equal (DatabaseParameters::operator==), in
/// which case the views of a database built with `a` can be compared with those of one built with
/// `b`.
std::string FirstParameterDifference(const DatabaseParameters& a, const DatabaseParameters& b);

/// Appends the models of `shard` to `merged`. `merged_name` and `shard_name` name them in errors.
/// An empty `merged` (no models and no views) takes the shard's parameters and view sphere.
/// Throws silpose::Error naming the shard if its parameters or view sphere differ from the merged
/// database's, or one of its model names is already in it.
void AppendDatabase(ViewDatabase&& shard, const std::string& shard_name, ViewDatabase* merged,
                    const std::string& merged_name = "the databases before it");

/// Reads the database files and merges them in the given order (AppendDatabase). Throws
/// silpose::Error naming the file if one cannot be read, was made with other parameters than the
/// first, or holds a model another file holds too, or if no file is given.
ViewDatabase MergeViewDatabases(const std::vector<std::filesystem::path>& paths);

}  // namespace silpose
