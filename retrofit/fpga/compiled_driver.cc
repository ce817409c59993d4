// The compiled simulation's driver: the gateware (CXXRTL, included as DESIGN_CC) with the host model of
// retrofit/fpga/simulate.py, clock for clock: prime the FIFOs, then run; one record a clock into the
// first FIFO with room (round robin from the tick's); the pins logged as (tick, levels) at each change.
#include <cstdint>
#include <vector>
#include DESIGN_CC

namespace {

struct Gate {
	cxxrtl_design::p_top top;
	int k, n, nq, depth;
	int64_t stop_tick, tick = 0, cycles = 0, fault_tick = -1;
	uint32_t seen = 0, last_pins = 0xffffffffu;
	bool started = false;
	std::vector<std::vector<uint64_t>> queues;      // per FIFO: lo, hi of each record
	std::vector<int64_t> heads, late;               // next record, held-back-until tick (-1: none)
	std::vector<int64_t> log_ticks;
	std::vector<uint32_t> log_pins;

	uint32_t watch() { return top.p_watch.template get<uint32_t>(); }

	// a rising edge (the registers take the inputs set), then the clock low: the outputs settle
	// (CXXRTL computes them in the evaluation before its registers commit)
	void clock() {
		top.p_clk.set<bool>(true);
		top.step();
		top.p_clk.set<bool>(false);
		top.step();
	}

	void set_data(const uint64_t *word) {
		auto &data = top.p_wr__data;
		for (size_t c = 0; c < data.chunks; c++) {
			uint64_t half = word[c * 32 / 64];
			data.data[c] = (uint32_t)(half >> (c * 32 % 64));
		}
	}

	void feed(int64_t at, uint32_t seen_now) {
		for (int j = 0; j < nq; j++) {
			int a = (int)((at + j) % nq);
			bool held = late[a] >= 0 && heads[a] >= 1 && at < late[a];
			if ((size_t)heads[a] * 2 < queues[a].size() && !held && (seen_now >> (2 * n + a) & 1)) {
				top.p_wr__axis.set<uint32_t>(a);
				set_data(&queues[a][heads[a] * 2]);
				top.p_wr__en.set<bool>(true);
				heads[a]++;
				return;
			}
		}
		top.p_wr__en.set<bool>(false);
	}

	void next_inputs() {          // what the host sets before the next clock
		if (stop_tick >= 0 && tick >= stop_tick)
			top.p_stop.set<bool>(true);
		feed(tick, seen);
	}

	void start() {
		top.p_clk.set<bool>(false);
		top.step();
		for (int i = 0; i < depth * nq + 2; i++) {
			feed(0, watch());
			clock();
		}
		top.p_run.set<bool>(true);
		top.step();
		seen = watch();
		next_inputs();
		started = true;
	}

	void run_to(int64_t end) {
		if (!started)
			start();
		uint32_t mask = (1u << (2 * n)) - 1, alarms = 2 * n + nq;
		while (tick < end) {
			clock();
			seen = watch();
			cycles++;
			if (k > 1 && (cycles - 1) % k) {
				next_inputs();
				continue;
			}
			if ((seen & mask) != last_pins) {
				last_pins = seen & mask;
				log_ticks.push_back(tick);
				log_pins.push_back(last_pins);
			}
			if (fault_tick < 0 && (seen >> alarms))
				fault_tick = tick;
			tick++;
			next_inputs();
		}
	}
};

}  // namespace

extern "C" {

void *gate_new(int k, int n, int nq, int depth, int64_t stop_tick) {
	Gate *g = new Gate();
	g->k = k, g->n = n, g->nq = nq, g->depth = depth, g->stop_tick = stop_tick;
	g->queues.resize(nq);
	g->heads.assign(nq, 0);
	g->late.assign(nq, -1);
	return g;
}

void gate_free(void *g) { delete (Gate *)g; }

void gate_hold(void *g, int q, int64_t until) { ((Gate *)g)->late[q] = until; }

void gate_add(void *g, int q, const uint64_t *words, int64_t count) {
	auto &queue = ((Gate *)g)->queues[q];
	queue.insert(queue.end(), words, words + 2 * count);
}

void gate_run_to(void *g, int64_t end) { ((Gate *)g)->run_to(end); }

// the pins logged since the last call (at most ``room``); returns how many were copied
int64_t gate_take(void *gp, int64_t *ticks, uint32_t *pins, int64_t room) {
	Gate *g = (Gate *)gp;
	int64_t count = std::min<int64_t>(room, g->log_ticks.size());
	std::copy(g->log_ticks.begin(), g->log_ticks.begin() + count, ticks);
	std::copy(g->log_pins.begin(), g->log_pins.begin() + count, pins);
	g->log_ticks.erase(g->log_ticks.begin(), g->log_ticks.begin() + count);
	g->log_pins.erase(g->log_pins.begin(), g->log_pins.begin() + count);
	return count;
}

// tick, cycles, fault tick (-1: none), the alarms (bit 0 underrun, bit 1 fault), then each axis's position
void gate_status(void *gp, int64_t *out) {
	Gate *g = (Gate *)gp;
	out[0] = g->tick, out[1] = g->cycles, out[2] = g->fault_tick;
	out[3] = g->seen >> (2 * g->n + g->nq) & 3;
	auto &pos = g->top.p_pos;
	for (int a = 0; a < g->n; a++) {
		int64_t v = 0;
		for (int b = 0; b < 24; b++) {
			int bit = a * 24 + b;
			v |= (int64_t)(pos.data[bit / 32] >> (bit % 32) & 1) << b;
		}
		out[4 + a] = v >= (1 << 23) ? v - (1 << 24) : v;
	}
}

}
