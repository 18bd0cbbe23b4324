// SPDX-License-Identifier: GPL-2.0
/*
 * bywire_i2c_sim: an I2C adapter that carries plain I2C transfers (I2C_RDWR, i2c_master_send),
 * for the kernel tier (tests/kernel); the kernel's i2c-stub carries SMBus transfers only.
 *
 * One device answers, at `address` (default 0x4c, a DAC6574): it acknowledges every write and
 * keeps the last 64 messages written to it, read back from the adapter's `written` attribute:
 * one message a line, oldest first, "<sequence number> <hex bytes>" (numbered from 1 since the
 * module was loaded, so a reader can tell what it has seen); `latest` holds the last message for
 * each first byte (a DAC6574's control byte: one per channel and kind), in the same form, so
 * the state of the device can be read at any time, however many messages went by. Reads
 * return zeros. Every other address, and this one while `present` is 0 (a device that lost power or
 * its cable), does not acknowledge: the transfer fails with ENXIO, as bus drivers report a NAK.
 */
#include <linux/i2c.h>
#include <linux/module.h>
#include <linux/mutex.h>

#define KEPT 64
#define MAX_LEN 8
static unsigned short address = 0x4c;
module_param(address, ushort, 0444);
MODULE_PARM_DESC(address, "7-bit address of the simulated device");

struct kept_message {
	u64 sequence;
	u8 len;
	u8 buf[MAX_LEN];
};

static struct kept_message kept[KEPT];
static unsigned int kept_count, kept_next;
static u64 sequence;
static struct kept_message latest[256];
static bool present = true;
static DEFINE_MUTEX(lock);

static void keep(const struct i2c_msg *msg)
{
	struct kept_message *slot = &kept[kept_next];

	slot->sequence = ++sequence;
	slot->len = min_t(u16, msg->len, MAX_LEN);
	memcpy(slot->buf, msg->buf, slot->len);
	kept_next = (kept_next + 1) % KEPT;
	if (slot->len)
		latest[slot->buf[0]] = *slot;
	kept_count = min(kept_count + 1, (unsigned int)KEPT);
}

static int sim_xfer(struct i2c_adapter *adapter, struct i2c_msg *msgs, int num)
{
	int i;

	mutex_lock(&lock);
	for (i = 0; i < num; i++) {
		if (msgs[i].addr != address || !present) {
			mutex_unlock(&lock);
			return -ENXIO;
		}
		if (msgs[i].flags & I2C_M_RD)
			memset(msgs[i].buf, 0, msgs[i].len);
		else
			keep(&msgs[i]);
	}
	mutex_unlock(&lock);
	return num;
}

static u32 sim_functionality(struct i2c_adapter *adapter)
{
	return I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL;
}

static const struct i2c_algorithm sim_algorithm = {
	.master_xfer = sim_xfer,
	.functionality = sim_functionality,
};

static struct i2c_adapter sim_adapter = {
	.owner = THIS_MODULE,
	.algo = &sim_algorithm,
	.name = "bywire-i2c-sim",
};

static ssize_t written_show(struct device *dev, struct device_attribute *attr, char *buf)
{
	unsigned int i, j, first;
	ssize_t len = 0;

	mutex_lock(&lock);
	first = (kept_next + KEPT - kept_count) % KEPT;
	for (i = 0; i < kept_count; i++) {
		const struct kept_message *message = &kept[(first + i) % KEPT];

		len += sysfs_emit_at(buf, len, "%llu ", message->sequence);
		for (j = 0; j < message->len; j++)
			len += sysfs_emit_at(buf, len, "%02x", message->buf[j]);
		len += sysfs_emit_at(buf, len, "\n");
	}
	mutex_unlock(&lock);
	return len;
}

static DEVICE_ATTR_RO(written);

static ssize_t latest_show(struct device *dev, struct device_attribute *attr, char *buf)
{
	unsigned int first, j;
	ssize_t len = 0;

	mutex_lock(&lock);
	for (first = 0; first < ARRAY_SIZE(latest); first++) {
		if (!latest[first].len)
			continue;
		len += sysfs_emit_at(buf, len, "%llu ", latest[first].sequence);
		for (j = 0; j < latest[first].len; j++)
			len += sysfs_emit_at(buf, len, "%02x", latest[first].buf[j]);
		len += sysfs_emit_at(buf, len, "\n");
	}
	mutex_unlock(&lock);
	return len;
}
static DEVICE_ATTR_RO(latest);

static ssize_t present_show(struct device *dev, struct device_attribute *attr, char *buf)
{
	return sysfs_emit(buf, "%d\n", present);
}

static ssize_t present_store(struct device *dev, struct device_attribute *attr,
			     const char *buf, size_t count)
{
	bool value;
	int ret = kstrtobool(buf, &value);

	if (ret)
		return ret;
	mutex_lock(&lock);
	present = value;
	mutex_unlock(&lock);
	return count;
}
static DEVICE_ATTR_RW(present);

static int __init sim_init(void)
{
	int ret = i2c_add_adapter(&sim_adapter);

	if (ret)
		return ret;
	ret = device_create_file(&sim_adapter.dev, &dev_attr_written);
	if (!ret)
		ret = device_create_file(&sim_adapter.dev, &dev_attr_present);
	if (!ret)
		ret = device_create_file(&sim_adapter.dev, &dev_attr_latest);
	if (ret)
		i2c_del_adapter(&sim_adapter);
	return ret;
}

static void __exit sim_exit(void)
{
	device_remove_file(&sim_adapter.dev, &dev_attr_latest);
	device_remove_file(&sim_adapter.dev, &dev_attr_present);
	device_remove_file(&sim_adapter.dev, &dev_attr_written);
	i2c_del_adapter(&sim_adapter);
}

module_init(sim_init);
module_exit(sim_exit);
MODULE_DESCRIPTION("I2C adapter with one simulated device for bywire's kernel tier");
MODULE_LICENSE("GPL");
