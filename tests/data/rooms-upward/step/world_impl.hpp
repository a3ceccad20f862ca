// The step/ header tests/data/rooms-upward/model/upward.cpp includes (never compiled).
