// Test vectors for bnerr's port of OpenQMC's blue-noise samplers (bnerr/sequences/openqmc.py).
//
// Built against OpenQMC's own headers (github.com/AcademySoftwareFoundation/openqmc, Apache-2.0,
// commit 294d65627f667b668373250a751862232cf21d65); README.md beside this file says how. For every
// lane (sampler, x, y, frame, index, domain key) it prints what
//
//     Sampler(x, y, frame, index, cache).newDomain(key).drawSample<4>(...)
//
// returns, as the four uint32 words and as the four float32 bit patterns of the float overload,
// one lane per line in hex. Then the float conversion uintToFloat of a list of edge words. The
// lanes are a fixed function of the code below (no clock, no RNG state), so a rerun prints the
// same text.
#include <oqmc/float.h>
#include <oqmc/latticebn.h>
#include <oqmc/sobolbn.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

namespace
{

std::uint32_t bits(float value)
{
	std::uint32_t out;
	std::memcpy(&out, &value, sizeof(out));
	return out;
}

// A small counter-based hash (lowbias32) to pick "random" lanes reproducibly.
std::uint32_t mix(std::uint32_t x)
{
	x ^= x >> 16;
	x *= 0x7feb352dU;
	x ^= x >> 15;
	x *= 0x846ca68bU;
	x ^= x >> 16;
	return x;
}

template <typename Sampler>
void lanes(const char* name)
{
	void* cache = new std::byte[Sampler::cacheSize];
	Sampler::initialiseCache(cache);

	// Pixels: the tile's corners, pixels past the 256x256 tile (wrap), negative ones, and a hashed few.
	std::vector<std::pair<int, int>> pixels = {
	    {0, 0},     {1, 0},    {0, 1},      {255, 255}, {256, 0},  {0, 256},
	    {511, 300}, {-1, -1},  {-300, 17},  {1919, 1079}, {37, 11}, {128, 64},
	};
	for(std::uint32_t i = 0; pixels.size() < 24; ++i)
	{
		const auto h = mix(i + 0x1234U);
		pixels.push_back({int(h & 0xfff), int((h >> 12) & 0xfff)});
	}

	// Indices: the first 32, and past the tables' 128, at and past 2^16 (the pattern's index key).
	std::vector<int> indices;
	for(int i = 0; i < 32; ++i)
	{
		indices.push_back(i);
	}
	for(int i : {127, 128, 255, 1000, 65535, 65536, 65537, 1 << 20})
	{
		indices.push_back(i);
	}

	const int frames[] = {0, 7};
	const int keys[] = {0, 1, 5};

	for(const auto& [x, y] : pixels)
	{
		for(int frame : frames)
		{
			for(int index : indices)
			{
				for(int key : keys)
				{
					const auto domain = Sampler(x, y, frame, index, cache).newDomain(key);
					std::uint32_t words[4];
					float values[4];
					domain.template drawSample<4>(words);
					domain.template drawSample<4>(values);
					std::printf("%s %d %d %d %d %d", name, x, y, frame, index, key);
					for(auto w : words)
					{
						std::printf(" %08x", w);
					}
					for(auto v : values)
					{
						std::printf(" %08x", bits(v));
					}
					std::printf("\n");
				}
			}
		}
	}

	delete[] static_cast<std::byte*>(cache);
}

void floats()
{
	std::vector<std::uint32_t> words = {
	    0x00000000U, 0x00000001U, 0x00ffffffU, 0x01000000U, 0x01000001U, 0x7fffffffU,
	    0x80000000U, 0xfffffe7fU, 0xffffff00U, 0xffffff7fU, 0xffffff80U, 0xffffffffU,
	};
	for(std::uint32_t i = 0; words.size() < 1024; ++i)
	{
		words.push_back(mix(i ^ 0xabcdU));
	}
	for(auto w : words)
	{
		std::printf("float %08x %08x\n", w, bits(oqmc::uintToFloat(w)));
	}
}

} // namespace

int main()
{
	lanes<oqmc::SobolBnSampler>("sobolbn");
	lanes<oqmc::LatticeBnSampler>("latticebn");
	floats();
	return 0;
}
