// The translation unit pg_pch compiles its precompiled header with (cmake/pg_helpers.cmake).
