"""The sync tables of a site's database: SQL in, typed rows out."""
